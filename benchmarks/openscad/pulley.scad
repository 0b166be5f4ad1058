// V-belt pulley by rotate_extrude of a profile, with bore and set-screw hole
$fn=96;
difference(){
  rotate_extrude() polygon([[5,0],[30,0],[30,2],[25,8],[25,10],[30,16],[30,18],[12,18],[12,26],[5,26]]);
  translate([0,0,22]) rotate([90,0,0]) cylinder(d=4,h=20,$fn=24);
}
