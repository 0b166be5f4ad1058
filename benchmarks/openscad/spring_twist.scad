// twisted extrusion (drill-like), a spring-ish twisted square with offset
linear_extrude(height=60, twist=540, slices=120, $fn=32)
  translate([4,0]) square([3,3],center=true);
