// knurled knob: rotate_extrude body minus 30 grooves, D-shaft bore
$fn=64;
difference(){
  rotate_extrude() polygon([[0,0],[15,0],[15,14],[13,18],[0,18]]);
  for(i=[0:29]) rotate(i*12) translate([15.6,0,-1]) cylinder(d=2,h=15,$fn=12);
  translate([0,0,-1]) difference(){ cylinder(d=6,h=12,$fn=32); translate([1.5,-5,0]) cube([10,10,14]); }
}
