// M12 hex nut with chamfers (intersection with double cone), plain bore
difference(){
  intersection(){
    cylinder(d=20.78,h=10,$fn=6);
    union(){ cylinder(d1=18,d2=18+2*10,h=10,$fn=64); }
    translate([0,0,10]) rotate([180,0,0]) cylinder(d1=18,d2=38,h=10,$fn=64);
  }
  translate([0,0,-1]) cylinder(d=10.2,h=12,$fn=48);
}
