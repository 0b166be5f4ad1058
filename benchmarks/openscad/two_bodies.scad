// two separate parts in one file: a washer and a bushing side by side
$fn=64;
difference(){ cylinder(d=30,h=3); translate([0,0,-1]) cylinder(d=13,h=5); }
translate([40,0,0]) difference(){ union(){ cylinder(d=16,h=20); cylinder(d=22,h=3);} translate([0,0,-1]) cylinder(d=10,h=22); }
