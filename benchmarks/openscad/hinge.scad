// hinge leaf with knuckles and pin hole, small gaps between knuckles
$fn=40;
difference(){
  union(){ cube([40,25,2]); for(i=[0,2,4]) translate([i*8,0,3]) rotate([0,90,0]) cylinder(d=6,h=7.6); translate([0,-3,0]) cube([40,3,3]); }
  translate([-1,0,3]) rotate([0,90,0]) cylinder(d=2.2,h=42);
  for(x=[8,32]) translate([x,15,-1]) cylinder(d=3.5,h=5);
}
