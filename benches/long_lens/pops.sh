#!/bin/bash
# The long-lens populations of docs/calib-single.md, section 6 ("Long lenses"), from the
# repository root after `cargo build --release -p calib-cli`, with a Python that has cv2 (OpenCV
# 5) and numpy:  PYTHON=/path/to/python bash benches/long_lens/pops.sh [SEEDS]
S=${1:-50}
P="${PYTHON:-python3} $(dirname "$0")/run.py"
for fov in 15 8 4 2; do
  $P m_fov$fov $S "{\"W\":2448,\"H\":2048,\"hfov\":$fov,\"views\":15,\"noise\":0.2}" --cv --nf
done
for fov in 15 4; do
  $P l_fov$fov $S "{\"W\":4096,\"H\":3000,\"hfov\":$fov,\"views\":20,\"noise\":0.3}" --cv --nf
done
for v in 4 60; do
  $P views${v}_fov6 $S "{\"W\":2448,\"H\":2048,\"hfov\":6,\"views\":$v,\"noise\":0.2}" --cv
done
for n in 0.05 0.5; do
  $P noise${n}_fov6 $S "{\"W\":2448,\"H\":2048,\"hfov\":6,\"views\":15,\"noise\":$n}" --cv
done
$P zerodist_fov4 $S '{"W":2448,"H":2048,"hfov":4,"views":15,"noise":0.2,"dist":[0,0,0,0]}' --cv --nf
$P bc5_fov8 $S '{"W":2448,"H":2048,"hfov":8,"views":15,"noise":0.2,"model":"brown-conrady5"}' --cv --extra "--model brown-conrady5"
$P tilt10_20_fov6 $S '{"W":2448,"H":2048,"hfov":6,"views":15,"noise":0.2,"tilt":[10,20]}' --cv
$P tilt30_50_fov6 $S '{"W":2448,"H":2048,"hfov":6,"views":15,"noise":0.2,"tilt":[30,50]}' --cv
$P smallboard_fov6 $S '{"W":2448,"H":2048,"hfov":6,"views":15,"noise":0.2,"frac":[0.1,0.25]}' --cv
$P ppoff10_fov8 $S '{"W":2448,"H":2048,"hfov":8,"views":15,"noise":0.2,"pp_off":0.1}' --cv
# remedies the warnings offer
for fov in 15 8 4 2; do
  $P fpp_m_fov$fov $S "{\"W\":2448,\"H\":2048,\"hfov\":$fov,\"views\":15,\"noise\":0.2}" --cv --extra="--fix-principal-point"
done
for fov in 8 2; do
  $P fk2_m_fov$fov $S "{\"W\":2448,\"H\":2048,\"hfov\":$fov,\"views\":15,\"noise\":0.2}" --extra="--fix k2"
done
TRUTHSTART=1 $P ts_zerodist_fov4 100 '{"W":2448,"H":2048,"hfov":4,"views":15,"noise":0.2,"dist":[0,0,0,0]}' --cv
# telephoto stereo pairs (docs/calib-stereo.md)
Q="${PYTHON:-python3} $(dirname "$0")/stereo.py"
ST="--image 2448x2048 --intrinsics 20000,20000,1250,1000 --distortion=0.05,0,0,0 --right-intrinsics 20100,20100,1200,1050 --right-distortion=-0.05,0,0,0 --rig 0,0.0756,0,-498.6,0,37.8"
$Q st_f20k 40 "--views 15 $ST"
$Q st_f20k_v40 40 "--views 40 $ST"
$Q st_f20k_fpp 40 "--views 15 $ST" "--fix-principal-point"
$Q st_f45k 40 "--views 15 --image 4096x3000 --intrinsics 45000,45000,2100,1450 --distortion=0,0,0,0 --right-intrinsics 45200,45200,2000,1550 --right-distortion=0,0,0,0 --rig 0,0.2223,0,-975.4,0,220.5"
