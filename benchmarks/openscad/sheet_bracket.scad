// sheet-metal Z bracket, 1.5 mm sheet, bends as quarter tubes, two holes per flange
$fn=32; t=1.5; r=2; w=30;
module bend(){ rotate([-90,0,0]) difference(){ cylinder(r=r+t,h=w); translate([0,0,-1]) cylinder(r=r,h=w+2); translate([-10,-20,-1]) cube([20,20,w+2]); translate([-20,-10,-1]) cube([20,20,w+2]); } }
difference(){
  union(){
    translate([-40,0,-t-r]) cube([40,w,t]);          // lower flange, top at z=-r
    translate([0,0,0]) rotate([0,-90,0]) bend();
    translate([r,0,0]) cube([t,w,40]);
  }
  for(y=[8,22]) translate([-25,y,-10]) cylinder(d=4.5,h=20);
  for(y=[8,22]) translate([0,y,25]) rotate([0,90,0]) cylinder(d=4.5,h=20);
}
