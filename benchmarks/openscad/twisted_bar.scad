// twisted star column (vase-like), linear_extrude with twist and scale
linear_extrude(height=50, twist=120, slices=60, scale=0.6)
  offset(r=1,$fn=24) polygon([for(i=[0:9]) let(r=(i%2)?10:18) [r*cos(i*36), r*sin(i*36)]]);
