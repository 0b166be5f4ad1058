// block with tiny edge fillets (r=0.3 at $fn=32): many small facets on a 60 mm part
module rcube(s,r){ hull(){ for(x=[r,s[0]-r],y=[r,s[1]-r],z=[r,s[2]-r]) translate([x,y,z]) sphere(r=r,$fn=32);} }
difference(){ rcube([60,40,20],0.3); translate([30,20,-1]) cylinder(d=12,h=30,$fn=64); }
