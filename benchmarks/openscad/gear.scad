// spur gear: 24 trapezoid teeth, hub, keyway, lightening holes
$fn=64; z=24; m=2; r=z*m/2;
module tooth(){ polygon([[r-1.25*m,-1.6],[r+m,-0.7],[r+m,0.7],[r-1.25*m,1.6]]); }
difference(){
  union(){
    linear_extrude(8) union(){ circle(r=r-1.25*m+0.2); for(i=[0:z-1]) rotate(i*360/z) tooth(); }
    cylinder(d=18,h=14);
  }
  translate([0,0,-1]) cylinder(d=8,h=20);
  translate([3,-1.5,-1]) cube([3,3,20]);
  for(i=[0:3]) rotate(i*90+45) translate([11,0,-1]) cylinder(d=5,h=20,$fn=32);
}
