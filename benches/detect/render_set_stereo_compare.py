"""The stereo check of a set rendered by `render_set ... --stereo`: R, T of `calib stereo ... -o
DIR/st.json` against DIR/truth.json (angle of R_est R_true^T in degrees, z of the rotation and of T
in the reported sigmas) and z of each camera's intrinsics and coefficients. Usage:
    python benches/detect/render_set_stereo_compare.py DIR   (numpy needed)"""
import json,sys,numpy as np,math
d=sys.argv[1]; o=json.load(open(f'{d}/st.json')); t=json.load(open(f'{d}/truth.json'))
R=np.array(o['R']); Rt=np.array(t['R']); dR=R@Rt.T
ang=math.degrees(math.acos(min(1,(np.trace(dR)-1)/2)))
T=np.array(o['T']); Tt=np.array(t['T'])
print(d,'rms',o['rms'],'warnings',[w['code'] for w in o['warnings']],'rejected',o.get('rejected_pairs'))
print(' dR deg %.5f'%ang,'T',T.round(4),'truth',Tt.round(4))
std=o.get('rig_std')
if std:
    D=R.T@Rt; w2=np.array([D[2,1]-D[1,2],D[0,2]-D[2,0],D[1,0]-D[0,1]])/2
    print(' z rot',np.round(w2/np.array(std[:3]),2),'z T',np.round((T-Tt)/np.array(std[3:6]),2))
for side in ('left','right'):
    c=o[side]; tc=t['camera'] if side=='left' else t['right']
    z=[(c[n]-tc[n])/c['std'][n] for n in ('fx','fy','cx','cy')]+[(a-b)/s for a,b,s in zip(c['dist_coeffs'],tc['dist_coeffs'],c['std']['dist_coeffs'])]
    print(' ',side,'z',np.round(z,2))
