#!/usr/bin/env python3
"""Correlation of the dot centroid errors with the luma gradient of the ring around each
dot (a light gradient that would pull a luma-weighted centroid).

Usage: ring_gradient.py SESSION OUT   (SESSION rendered with --png: one photo per pressure)
"""
import csv, json, numpy as np, cv2, sys
S,O=sys.argv[1],sys.argv[2]
T=json.load(open(S+'/truth-pbr.json'))
px={}
for r in csv.DictReader(open(O+'/markers.csv')):
    px.setdefault(r['file'],{}).setdefault(int(r['marker']),[]).append((float(r['x_px']),float(r['y_px'])))
G=[];E=[]
for v in T['videos']:
    img=cv2.imread(S+'/'+v['file']).astype(float)
    Y=0.299*img[...,2]+0.587*img[...,1]+0.114*img[...,0]
    for k,(u,w) in enumerate(v['dots_px']):
        e=np.mean(px[v['file']][k+1],axis=0)-[u,w]
        iu,iw=int(round(u)),int(round(w)); R=12
        yy,xx=np.mgrid[-R:R+1,-R:R+1]; X=xx+iu-u; Yc=yy+iw-w; rr=np.hypot(X,Yc)
        m=(rr>7.5)&(rr<11); win=Y[iw-R:iw+R+1,iu-R:iu+R+1]
        A=np.c_[np.ones(m.sum()),X[m],Yc[m]]; c=np.linalg.lstsq(A,win[m],rcond=None)[0]
        G.append(c[1:]); E.append(e)
G=np.array(G);E=np.array(E)
print('corr x',np.corrcoef(G[:,0],E[:,0])[0,1],'corr y',np.corrcoef(G[:,1],E[:,1])[0,1])
# regression E = a*G
a=(G*E).sum()/(G*G).sum(); print('E = %.4f px per (luma/px) * grad'%a, 'resid rms',np.sqrt(((E-a*G)**2).mean()),'E rms',np.sqrt((E**2).mean()), 'grad rms', np.sqrt((G**2).mean()))
