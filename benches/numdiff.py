#!/usr/bin/env python3
"""Compare two text outputs of the same run number by number.

    python3 benches/numdiff.py OLD NEW

Prints how many lines differ and the largest difference in units of the last printed
digit (the files must have the same number of lines).
"""
import sys
a=open(sys.argv[1]).read().split('\n'); b=open(sys.argv[2]).read().split('\n')
assert len(a)==len(b), (len(a),len(b))
mx=0; worst=None; nd=0
for i,(x,y) in enumerate(zip(a,b)):
    if x==y: continue
    nd+=1
    xs=x.split(); ys=y.split()
    for j,(u,v) in enumerate(zip(xs,ys)):
        if u==v: continue
        try: fu=float(u); fv=float(v)
        except: continue
        dec=len(u.split('.')[1]) if '.' in u else 0
        ulp=10**-dec
        d=abs(fu-fv)/ulp
        if d>mx: mx=d; worst=(i,j,u,v)
print(f"{nd} lines differ; largest difference {mx:.1f} units of the last printed digit at {worst}")
