// 2x4 brick: hollow shell 1.2 mm, studs, three underside tubes
$fn=48; p=8; h=9.6; w=1.2;
difference(){ cube([4*p-0.2,2*p-0.2,h]); translate([w,w,-1]) cube([4*p-0.2-2*w,2*p-0.2-2*w,h-w+1]); }
for(i=[0:3],j=[0:1]) translate([p/2+i*p-0.1,p/2+j*p-0.1,h]) cylinder(d=4.8,h=1.8);
for(i=[1:3]) translate([i*p-0.1,p-0.1,0]) difference(){ cylinder(d=6.51,h=h-w); translate([0,0,-1]) cylinder(d=4.8,h=h); }
