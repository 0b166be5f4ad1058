// 80 mm fan guard: 2 mm plate, concentric ring slots joined by ribs, 4 screw holes
$fn=64;
difference(){
  hull(){ for(x=[-36,36],y=[-36,36]) translate([x,y,0]) cylinder(r=4,h=2); }
  for(x=[-35.75,35.75],y=[-35.75,35.75]) translate([x,y,-1]) cylinder(d=4.4,h=4);
  for(r=[12:8:36]) difference(){ translate([0,0,-1]) cylinder(r=r,h=4); translate([0,0,-2]) cylinder(r=r-4,h=6);
     for(a=[0:60:359]) rotate(a) translate([0,-1.5,-3]) cube([40,3,8]); }
}
