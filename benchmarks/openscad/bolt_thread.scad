// M8x30 hex bolt, thread made as twisted extrusion of an off-centre circle (common hack)
$fn=48;
cylinder(d=14.4,h=5.3,$fn=6);
translate([0,0,5.3]) linear_extrude(height=30, twist=-30/1.25*360, slices=240) translate([0.35,0]) circle(d=7.3,$fn=32);
