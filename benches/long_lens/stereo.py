# python stereo.py NAME SEEDS 'calib synth stereo args' ['calib stereo args']
# z of the rig's rotation (so3: a small rotation applied on the right, R = R_est exp([d]x)), of T
# and of both cameras' fx, fy, cx, cy over SEEDS seeds. CALIB names the binary, OUT the output.
import json, subprocess, sys, numpy as np, os
from multiprocessing import Pool
B=os.environ.get('CALIB','target/release/calib')
OUT=os.environ.get('OUT','long_lens_out')
name, S, sargs = sys.argv[1], int(sys.argv[2]), sys.argv[3].split()
cargs = sys.argv[4].split() if len(sys.argv) > 4 else []
os.makedirs(f'{OUT}/tmp', exist_ok=True); os.makedirs(f'{OUT}/res', exist_ok=True)
def logm(R):
    c=(np.trace(R)-1)/2; th=np.arccos(np.clip(c,-1,1))
    w=np.array([R[2,1]-R[1,2],R[0,2]-R[2,0],R[1,0]-R[0,1]])/2
    return w if th<1e-12 else w*th/np.sin(th)
def one(s):
    f=f'{OUT}/tmp/{name}_{s}.json'
    subprocess.run([B,'synth','stereo','--seed',str(s),'-o',f]+sargs,check=True,capture_output=True)
    p=subprocess.run([B,'stereo',f,'-q','-o',f+'.out','--threads','1']+cargs,capture_output=True,text=True)
    if p.returncode: return {'seed':s,'refused':p.stderr[-300:]}
    d=json.load(open(f+'.out')); t=json.load(open(f))['truth']
    Re=np.array(d['R']); Rt=np.array(t['R']); delta=logm(Re.T@Rt)
    sd=d['rig_std']; z=list(delta/np.array(sd[:3]))+list((np.array(t['T'])-np.array(d['T']))/np.array(sd[3:]))
    z=[-v for v in z]  # estimate - truth
    zc=[]
    for cam in ('left','right'):
        c=d[cam]; tc=t[cam]
        for k in ('fx','fy','cx','cy'):
            zc.append((c[k]-tc[k])/c['std'][k] if c['std'][k]>0 else 0.0)
    return {'seed':s,'z':z,'zc':zc,'warn':[w['code']+': '+w['message'][:80] for w in d['warnings']],'term':d['solver']['termination_code']}
with Pool(2) as p: recs=p.map(one, range(1,S+1))
ok=[r for r in recs if 'z' in r]
Z=np.array([r['z'] for r in ok]); ZC=np.array([r['zc'] for r in ok])
print(name, 'n',len(recs),'refused',len(recs)-len(ok),'rig zrms (r1 r2 r3 T1 T2 T3)',np.round(np.sqrt((Z**2).mean(0)),2),'max|z|',np.abs(Z).max().round(2),
      'cams zrms',np.round(np.sqrt((ZC**2).mean(0)),2),'max',np.abs(ZC).max().round(1),
      'terms',set(r['term'] for r in ok),'warned',sum(any('poorly' in w for w in r['warn']) for r in ok))
json.dump(recs,open(f'{OUT}/res/{name}.json','w'))
