// stepped shaft with chamfers, keyway and a cross-drilled hole
$fn=64;
difference(){
  union(){ cylinder(d=20,h=40); translate([0,0,40]) cylinder(d=25,h=20); translate([0,0,60]) cylinder(d1=20,d2=18,h=30); }
  translate([-3,6,10]) cube([6,5,22]);
  translate([0,0,75]) rotate([90,0,0]) cylinder(d=5,h=30,center=true,$fn=24);
}
