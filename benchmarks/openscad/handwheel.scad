// handwheel: rim torus, hub, 5 spokes
$fn=48;
rotate_extrude($fn=96) translate([50,0]) circle(r=5);
cylinder(d=20,h=16,center=true);
for(i=[0:4]) rotate(i*72) rotate([0,90,0]) cylinder(d=6,h=50);
