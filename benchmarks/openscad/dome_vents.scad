// hemispherical cover, 1.5 mm shell, with a grid of vent slots
$fn=64;
difference(){
  difference(){ sphere(d=60); sphere(d=57); translate([0,0,-50]) cube(100,center=true); }
  for(x=[-12:6:12]) translate([x,0,30]) cube([2.5,30,20],center=true);
}
