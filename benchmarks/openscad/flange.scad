// pipe flange: hub, raised face, bore, 8-bolt circle
$fn=64;
difference(){
  union(){ cylinder(d=120,h=14); cylinder(d=70,h=40); translate([0,0,14]) cylinder(d1=80,d2=70,h=6); }
  translate([0,0,-1]) cylinder(d=50,h=50);
  for(i=[0:7]) rotate([0,0,i*45]) translate([47,0,-1]) cylinder(d=11,h=20);
}
