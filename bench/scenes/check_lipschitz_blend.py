#!/usr/bin/env python3
"""How far blobcast's converted Molecule lies from the original: samples
150 points on the surface of Lipschitz Pruning's molecule.json (their
chain of quadratic smooth unions, blend radius k, found by bisection along
random rays from sphere centres) and evaluates there our chain of compact
cubic smooth unions (docs/operators.md) for blend = 1.0, 1.44 and 1.5 k and
range = 1.25, 2, 4 and 10^6 blend. |ours| at their surface approximates the
distance between the two surfaces (both fields are close to distances
there). docs/benchmarks.md quotes the output. Standard library only;
spheres more than 0.5 away are treated as at 1.0, which changes no value
near the surface (both kernels vanish for operands more than k or blend
apart).

Usage: check_lipschitz_blend.py LipschitzPruning/scenes/molecule.json
"""
import json, math, random, sys
sys.setrecursionlimit(20000)
d=json.load(open(sys.argv[1]))
sph=[]; n=d
while n["nodeType"]!="primitive":
    r=n["rightChild"]; m=r["matrix"]; sph.append((-m[3],-m[7],-m[11],r["radius"])); n=n["leftChild"]
m=n["matrix"]; sph.append((-m[3],-m[7],-m[11],n["radius"])); sph.reverse()
k=d["blendRadius"]
def dists(p):
    return [math.sqrt((p[0]-x)**2+(p[1]-y)**2+(p[2]-z)**2)-r for x,y,z,r in sph]
def theirs(ds):
    acc=None
    for c in ds:
        if c>0.5: c=1.0
        if acc is None: acc=c; continue
        h=max(0,k-abs(acc-c)); acc=min(acc,c)-h*h*0.25/k
    return acc
def ours(ds,beta,rng):
    acc=None
    for c in ds:
        if c>0.5: c=1.0
        if acc is None: acc=c; continue
        if acc>rng or c>rng: acc=min(acc,c); continue
        g=min(acc,c)-beta/6*max(1-abs(acc-c)/beta,0)**3
        den=6*rng-beta
        b2=beta*max(1-6*g/den,0)
        acc=min(acc,c)-(b2/6*max(1-abs(acc-c)/b2,0)**3 if b2>0 else 0)
    return acc
random.seed(3)
pts=[]
while len(pts)<150:
    x,y,z,r=random.choice(sph)
    v=[random.gauss(0,1) for _ in range(3)]; nv=math.sqrt(sum(a*a for a in v)); v=[a/nv for a in v]
    # march out from centre to find their surface
    lo,hi=0.0,0.2
    f=lambda t: theirs(dists([x+v[0]*t,y+v[1]*t,z+v[2]*t]))
    if f(hi)<=0: continue
    if f(lo)>=0: continue
    for _ in range(25):
        mid=(lo+hi)/2
        if f(mid)<0: lo=mid
        else: hi=mid
    pts.append(dists([x+v[0]*lo,y+v[1]*lo,z+v[2]*lo]))
print("sphere radius",sph[0][3],"k",k)
for bs in (1.0,1.44,1.5):
    for rs in (1.25,2.0,4.0,1e6):
        vals=sorted(abs(ours(ds,bs*k,rs*bs*k)) for ds in pts)
        print("beta=%.2fk range=%gbeta: |ours| on their surface: median %.5f p90 %.5f max %.5f (x radius: max %.3f)"%(bs,rs,vals[len(vals)//2],vals[int(len(vals)*0.9)],vals[-1],vals[-1]/sph[0][3]))
