// electronics enclosure: rounded shell, 2 mm walls, four screw bosses, cable hole
$fn=40;
module rbox(w,l,h,r){ hull(){ for(x=[r,w-r],y=[r,l-r]) translate([x,y,0]) cylinder(r=r,h=h);} }
difference(){
  union(){
    difference(){ rbox(80,50,30,5); translate([2,2,2]) rbox(76,46,30,3); }
    for(x=[7,73],y=[7,43]) translate([x,y,0]) cylinder(d=7,h=26);
  }
  for(x=[7,73],y=[7,43]) translate([x,y,4]) cylinder(d=2.8,h=30,$fn=24);
  translate([-1,25,15]) rotate([0,90,0]) cylinder(d=8,h=5);
}
