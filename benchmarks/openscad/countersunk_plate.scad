// mounting plate with four countersunk holes and a counterbored centre hole
$fn=48;
difference(){
  cube([80,60,8]);
  for(x=[10,70],y=[10,50]) translate([x,y,0]){ translate([0,0,-1]) cylinder(d=5.5,h=10); translate([0,0,8-3]) cylinder(d1=5.5,d2=11.5,h=3.01); }
  translate([40,30,-1]) cylinder(d=10,h=10);
  translate([40,30,4]) cylinder(d=18,h=10);
}
