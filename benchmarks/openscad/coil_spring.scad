// compression spring: round wire swept along a helix as a polyhedron (5 turns, closed ends)
R=10; r=1.2; pitch=5; turns=5; n=24; m=16; N=turns*n;
function P(i,j)=let(a=360*i/n, z=pitch*i/n, b=360*j/m)
  [ (R+r*cos(b))*cos(a), (R+r*cos(b))*sin(a), z+r*sin(b) ];
pts=[for(i=[0:N]) for(j=[0:m-1]) P(i,j)];
side=[for(i=[0:N-1]) for(j=[0:m-1]) each [[i*m+j, (i+1)*m+j, (i+1)*m+(j+1)%m], [i*m+j, (i+1)*m+(j+1)%m, i*m+(j+1)%m]]];
caps=[[for(j=[0:m-1]) j], [for(j=[m-1:-1:0]) N*m+j]];
polyhedron(points=pts, faces=concat(side,caps));
