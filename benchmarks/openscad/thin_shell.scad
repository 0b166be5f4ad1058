// thin-walled cup: 100 mm tall, 1 mm wall, with a 1 mm rim flange
$fn=96;
difference(){
  union(){ cylinder(d=60,h=100); translate([0,0,99]) cylinder(d=70,h=1); }
  translate([0,0,1]) cylinder(d=58,h=100);
}
