// L bracket with rounded corners (hull of cylinders), slots and gusset
$fn=48;
module plate(w,l,t,r){ hull(){ for(x=[r,w-r],y=[r,l-r]) translate([x,y,0]) cylinder(r=r,h=t);} }
difference(){
  union(){
    plate(60,40,5,6);
    translate([0,0,0]) rotate([90,0,0]) translate([0,0,-5]) plate(60,45,5,6);
    hull(){ translate([27,0,5]) cube([6,1,30]); translate([27,0,5]) cube([6,30,1]); }
  }
  for(x=[12,48]) hull(){ for(y=[18,30]) translate([x,y,-1]) cylinder(d=6.5,h=10);}
  for(x=[12,48]) translate([x,6,30]) rotate([90,0,0]) cylinder(d=6.5,h=20);
}
