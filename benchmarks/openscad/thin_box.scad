// thin-walled tray 100x70x20 with 1 mm walls and a 1 mm rib
difference(){ cube([100,70,20]); translate([1,1,1]) cube([98,68,20]); }
translate([49.5,1,0]) cube([1,68,15]);
