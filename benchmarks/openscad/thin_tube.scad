// 100 mm tube, 20 mm diameter, 1 mm wall, with a 1 mm thick end flange
$fn=64;
difference(){ union(){ cylinder(d=20,h=100); cylinder(d=30,h=1);} translate([0,0,-1]) cylinder(d=18,h=102); }
