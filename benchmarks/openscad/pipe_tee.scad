// pipe tee: two cylinders unioned, both bored (thin wall 2.5 on 30 dia)
$fn=64;
difference(){
  union(){ rotate([0,90,0]) cylinder(d=30,h=100,center=true); cylinder(d=30,h=50); }
  rotate([0,90,0]) cylinder(d=25,h=102,center=true); cylinder(d=25,h=52);
}
