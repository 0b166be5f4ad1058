// block bracket with all edges filleted by minkowski with a sphere
difference(){
  minkowski(){ cube([50,30,12],center=true); sphere(r=3,$fn=24); }
  cylinder(d=14,h=40,center=true,$fn=64);
  for(x=[-20,20]) translate([x,0,0]) cylinder(d=5,h=40,center=true,$fn=32);
}
