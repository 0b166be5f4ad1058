// heat sink: base plate with 12 thin fins (1.2 mm)
cube([60,40,4]);
for(i=[0:11]) translate([1.5+i*5,0,4]) cube([1.2,40,25]);
