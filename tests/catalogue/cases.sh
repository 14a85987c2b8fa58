# shellcheck shell=bash
# The bad-input catalogue of ssc, read by run-catalogue.sh (docs/errors.md is its table).
#
#   def ID EXIT 'STDERR SUBSTRING[ && ANOTHER]' 'DESCRIPTION' 'SETUP' 'COMMAND' [FLAGS]
#
# SETUP and COMMAND are bash, run in the case's fresh working folder CASE/a/work (which holds
# precious.txt, a sentinel) with `ssc` on PATH and OMP_NUM_THREADS=1. Helpers (run-catalogue.sh):
#   fixture NAME...            copy tests/catalogue/fixtures/NAME into the working folder
#   scene FIX DEST FROM TO...  copy a fixture to DEST, replacing each literal FROM by TO (FROM must occur)
#   edit FILE FROM TO...       the same on a file in place
#   obs [DIR]                  a copy of the 16x16 depth renders of fixtures/ball.json (5 frames, 1 camera)
#   wait_for PATH [S]          poll until PATH exists;  track PID: kill PID if the case leaves it behind
# EXIT: 1 usage, 2 input, 3 simulation, 4 GPU/NVRTC, 130/143 interrupted; 0 only for warnings.
# Every command must leave the case folder byte-identical (no output created or changed);
# FLAGS: `pending` (planned behaviour, failure not counted), `writes` (may create files).
#
# Fixtures: ball.json (sphere r = 0.1 m at y = 0.15 over the ground, grid.resolution 8,
# dt 0.02 s, 4 steps, one 16x16 camera), mesh.json + cube.obj/.ply/.stl (0.2 m cube),
# sdf.json + ball.sdf (6^3 nodes), torus.json (thin torus), recording/ (a raw Open3D-layout depth
# recording for `ssc prepare`: a 0.2 m cube (cube.obj at --scan-scale 0.2) thrown above a table
# with clutter, 160x120, 5 frames at 30 fps, synthetic with a sensor model; written by
# PrepareCli.DISABLED_WritesTheCatalogueRecording in tests/test_prepare_cli.cpp).

SIM='ssc simulate scene.json --out out'
GRAD='ssc gradient ball.json --observations obs --params youngs_modulus'
SLOW='--set time.steps=1000000 --no-frames'

# ---- malformed or truncated JSON scenes ----
def json.malformed 2 'scene.json && not valid JSON' 'scene JSON with a syntax error (missing comma)' \
  'printf "{ \"object\": { \"primitive\": \"sphere\" \"radius\": 0.1 } }\n" > scene.json' "$SIM"
def json.truncated 2 'scene.json && not valid JSON' 'scene JSON cut off in the middle' \
  'head -c 300 "$FIX/ball.json" > scene.json' "$SIM"
def json.empty 2 'scene.json' 'empty scene file' \
  ': > scene.json' "$SIM"
def json.not-object 2 'scene.json' 'scene is a JSON array, not an object' \
  'echo "[1, 2, 3]" > scene.json' "$SIM"
def json.binary 2 'scene.json' 'scene file holds binary data (an .sdf renamed)' \
  'cp "$FIX/ball.sdf" scene.json' "$SIM"
def json.trailing 2 'scene.json' 'scene JSON followed by garbage' \
  'cp "$FIX/ball.json" scene.json; echo "}}" >> scene.json' "$SIM"

# ---- wrong types ----
def type.string-for-number 2 'scene.json && material.youngs_modulus' 'youngs_modulus given as a string "5000"' \
  'scene ball.json scene.json "\"youngs_modulus\": 5000" "\"youngs_modulus\": \"5000\""' "$SIM"
def type.bool-for-number 2 'material.density' 'density given as true' \
  'scene ball.json scene.json "\"density\": 100" "\"density\": true"' "$SIM"
def type.vector-length 2 'gravity' 'gravity with 2 components' \
  'scene ball.json scene.json "[0, -9.81, 0]" "[0, -9.81]"' "$SIM"
def type.position-length 2 'object.position' 'object.position with 4 components' \
  'scene ball.json scene.json "\"position\": [0, 0.15, 0]" "\"position\": [0, 0.15, 0, 1]"' "$SIM"
def type.steps-fraction 2 'time.steps' 'time.steps 4.5 (not an integer)' \
  'scene ball.json scene.json "\"steps\": 4" "\"steps\": 4.5"' "$SIM"
def type.object-not-object 2 'object' 'object given as a string' \
  'echo "{ \"object\": \"sphere\", \"grid\": { \"resolution\": 8 } }" > scene.json' "$SIM"

# ---- out-of-range values ----
def range.poisson-0.5 2 'material.poisson_ratio' 'poisson_ratio 0.5 (incompressible: must be < 0.5)' \
  'scene ball.json scene.json "\"poisson_ratio\": 0.4" "\"poisson_ratio\": 0.5"' "$SIM"
def range.density-negative 2 'material.density' 'density -100' \
  'scene ball.json scene.json "\"density\": 100" "\"density\": -100"' "$SIM"
def range.youngs-zero 2 'material.youngs_modulus' 'youngs_modulus 0' \
  'scene ball.json scene.json "\"youngs_modulus\": 5000" "\"youngs_modulus\": 0"' "$SIM"
def range.damping-negative 2 'material.mass_damping' 'mass_damping -0.1' \
  'scene ball.json scene.json "\"mass_damping\": 0.1" "\"mass_damping\": -0.1"' "$SIM"
def range.theta-0.3 2 'time.theta' 'theta 0.3 (unstable below 0.5)' \
  'scene ball.json scene.json "\"theta\": 0.6" "\"theta\": 0.3"' "$SIM"
def range.steps-negative 2 'time.steps' 'steps -1' \
  'scene ball.json scene.json "\"steps\": 4" "\"steps\": -1"' "$SIM"
def range.dt-zero 2 'time.dt' 'dt 0' \
  'scene ball.json scene.json "\"dt\": 0.02" "\"dt\": 0"' "$SIM"
def range.radius-negative 2 'radius' 'sphere radius -0.1' \
  'scene ball.json scene.json "\"radius\": 0.1" "\"radius\": -0.1"' "$SIM"
def range.torus-minor 2 'minor_radius' 'torus minor_radius larger than major_radius' \
  'scene torus.json scene.json "\"minor_radius\": 0.05" "\"minor_radius\": 0.5"' "$SIM"
def range.ground-normal-zero 2 'ground.normal' 'ground normal [0, 0, 0]' \
  'scene ball.json scene.json "\"normal\": [0, 1, 0]" "\"normal\": [0, 0, 0]"' "$SIM"
def range.grid-huge-resolution 2 'grid.resolution' 'grid.resolution 100000' \
  'scene ball.json scene.json "\"resolution\": 8" "\"resolution\": 100000"' "$SIM"
def range.grid-tiny-cell 2 'scene.json && grid.cell_size' 'grid.cell_size 1e-9 (a grid of 10^23 nodes)' \
  'scene ball.json scene.json "\"resolution\": 8" "\"cell_size\": 1e-9"' "$SIM"
def range.grid-both 2 'grid' 'grid with both cell_size and resolution' \
  'scene ball.json scene.json "\"resolution\": 8" "\"resolution\": 8, \"cell_size\": 0.03"' "$SIM"
def range.grid-missing 2 'grid' 'primitive scene without a grid section' \
  'scene ball.json scene.json "\"grid\": { \"resolution\": 8 }," ""' "$SIM"
def range.dirichlet-box 2 'dirichlet' 'dirichlet box with max below min' \
  'scene ball.json scene.json "\"time\"" "\"dirichlet\": [ { \"min\": [0, 0, 0], \"max\": [-1, 1, 1] } ], \"time\""' "$SIM"
def range.solver-tolerance 2 'solver.tolerance' 'solver.tolerance 2 (must be in (0, 1))' \
  'scene ball.json scene.json "\"time\"" "\"solver\": { \"tolerance\": 2 }, \"time\""' "$SIM"

# ---- unknown keys and names ----
def key.scene-typo 2 'youngs_modulis' 'misspelt material key youngs_modulis' \
  'scene ball.json scene.json "\"youngs_modulus\"" "\"youngs_modulis\""' "$SIM"
def key.top-level-typo 2 'gravty' 'misspelt top-level key gravty' \
  'scene ball.json scene.json "\"gravity\"" "\"gravty\""' "$SIM"
def key.primitive-name 2 'primitive' 'unknown primitive "cube"' \
  'scene ball.json scene.json "\"sphere\"" "\"cube\""' "$SIM"
def key.two-shapes 2 'object' 'object with both primitive and mesh' \
  'fixture cube.obj; scene ball.json scene.json "\"primitive\": \"sphere\"," "\"primitive\": \"sphere\", \"mesh\": \"cube.obj\","' "$SIM"
def key.cameras-unknown 0 'warning && colour' 'unknown key in cameras.json: a warning (also in the JSON result), the result is still useful' \
  'obs; edit obs/cameras.json "\"format\"" "\"colour\": \"red\", \"format\""; fixture ball.json' \
  'json=$(ssc gradient ball.json --observations obs --params youngs_modulus); rc=$?; grep -q colour <<<"$json" || { echo "catalogue: the JSON result has no warning about colour" >&2; exit 98; }; exit $rc'
def warn.grid-volume 0 'warning && grid.resolution' 'grid that loses 8.6 % of the torus volume: a warning, recorded in summary.json' \
  'scene torus.json scene.json "\"resolution\": 30" "\"resolution\": 20"' \
  'ssc simulate scene.json --out out --no-frames && grep -q grid_volume out/summary.json || { echo "catalogue: no grid_volume warning in out/summary.json" >&2; exit 98; }' writes

# ---- missing files; folders given as files ----
def missing.scene 2 'nope.json' 'scene file that does not exist' \
  '' 'ssc simulate nope.json --out out'
def missing.mesh 2 'gone.obj' 'mesh file that does not exist' \
  'scene mesh.json scene.json cube.obj gone.obj' "$SIM"
def missing.sdf-file 2 'gone.sdf' 'sdf_file that does not exist' \
  'scene sdf.json scene.json ball.sdf gone.sdf' "$SIM"
def missing.observations 2 'nowhere' 'observation folder that does not exist' \
  'fixture ball.json' 'ssc gradient ball.json --observations nowhere'
def missing.cameras-json 2 'cameras.json' 'observation folder without cameras.json' \
  'obs; rm obs/cameras.json; fixture ball.json' "$GRAD"
def missing.depth-png 2 'depth_0002.png && all-zero' 'one depth PNG in the middle of the frames missing (a gap: the fix is an all-zero PNG, not a lower frame_count)' \
  'obs; rm obs/cam0/depth_0002.png; fixture ball.json' "$GRAD"
def missing.frames 2 'depth_0005.png && frame_times' 'cameras.json (without frame_times) promises 9 frames, the folder has 5' \
  'obs; edit obs/cameras.json "\"frame_count\": 5" "\"frame_count\": 9" "\"frame_times\"" "\"unused_times\""; fixture ball.json' "$GRAD"
def missing.frame-times 2 'cameras.json && frame_times has 5 entries && frame_count = 9' 'cameras.json promises 9 frames and lists 5 frame_times' \
  'obs; edit obs/cameras.json "\"frame_count\": 5" "\"frame_count\": 9"; fixture ball.json' "$GRAD"
def folder.scene 2 'scene.json && folder' 'scene path is a folder' \
  'mkdir scene.json' "$SIM"
def folder.mesh 2 'cube.obj' 'mesh path is a folder' \
  'fixture mesh.json; mkdir cube.obj' 'ssc simulate mesh.json --out out'
def folder.observations-file 2 'ball.json && not a folder' '--observations names a file, not a folder' \
  'fixture ball.json' 'ssc gradient ball.json --observations ball.json'
def folder.sdf 2 'ball.sdf' 'sdf_file path is a folder' \
  'fixture sdf.json; mkdir ball.sdf' 'ssc simulate sdf.json --out out'
def folder.cameras-json 2 'cameras.json && folder' 'cameras.json is a folder' \
  'obs; rm obs/cameras.json; mkdir obs/cameras.json; fixture ball.json' "$GRAD"

# ---- meshes ----
def mesh.obj-garbage 2 'cube.obj' 'OBJ file of text that is not OBJ' \
  'fixture mesh.json; echo "this is not a mesh" > cube.obj' 'ssc simulate mesh.json --out out'
def mesh.obj-bad-index 2 'cube.obj' 'OBJ face with vertex index 99 of 8' \
  'fixture mesh.json cube.obj; echo "f 1 2 99" >> cube.obj' 'ssc simulate mesh.json --out out'
def mesh.obj-nan 2 'cube.obj' 'OBJ vertex with a nan coordinate' \
  'fixture mesh.json cube.obj; edit cube.obj "v 0.5 0.5 0.5" "v nan 0.5 0.5"' 'ssc simulate mesh.json --out out'
def mesh.obj-empty 2 'cube.obj' 'empty OBJ file' \
  'fixture mesh.json; : > cube.obj' 'ssc simulate mesh.json --out out'
def mesh.obj-flat 2 'cube.obj' 'OBJ of one triangle (no volume)' \
  'fixture mesh.json; printf "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n" > cube.obj' 'ssc simulate mesh.json --out out'
def mesh.obj-open 0 'warning && cube.obj && open' 'OBJ cube with three of its six faces missing: a warning that the mesh is open, recorded in summary.json' \
  'fixture mesh.json; head -n 15 "$FIX/cube.obj" > cube.obj' 'ssc simulate mesh.json --out out --no-frames && grep -q open_mesh out/summary.json || { echo "catalogue: no open_mesh warning in out/summary.json" >&2; exit 98; }' writes
def mesh.millimetres 2 'cube.obj && 200 m across && scale 0.001?' 'mesh in millimetres (a 200 m cube): besides the error it causes, a warning asks "scale 0.001?"' \
  'scene mesh.json mesh.json "\"scale\": 0.2" "\"scale\": 200"; fixture cube.obj' 'ssc simulate mesh.json --out out'
def mesh.ply-truncated 2 'cube.ply' 'ASCII PLY cut off after 3 of 8 vertices' \
  'scene mesh.json mesh.json cube.obj cube.ply; head -n 12 "$FIX/cube.ply" > cube.ply' 'ssc simulate mesh.json --out out'
def mesh.ply-garbage 2 'cube.ply' 'PLY file without a PLY header' \
  'scene mesh.json mesh.json cube.obj cube.ply; echo "solid nonsense" > cube.ply' 'ssc simulate mesh.json --out out'
def mesh.ply-binary-truncated 2 'cube.ply' 'binary PLY whose data ends after 5 bytes' \
  'scene mesh.json mesh.json cube.obj cube.ply; sed "s/format ascii 1.0/format binary_little_endian 1.0/;/end_header/q" "$FIX/cube.ply" > cube.ply; printf "\x01\x02\x03\x04\x05" >> cube.ply' 'ssc simulate mesh.json --out out'
def mesh.stl-truncated 2 'cube.stl' 'ASCII STL cut off inside a facet' \
  'scene mesh.json mesh.json cube.obj cube.stl; head -n 10 "$FIX/cube.stl" > cube.stl' 'ssc simulate mesh.json --out out'
def mesh.stl-binary-truncated 2 'cube.stl' 'binary STL that promises 12 triangles and holds none' \
  'scene mesh.json mesh.json cube.obj cube.stl; { head -c 80 /dev/zero; printf "\x0c\x00\x00\x00"; } > cube.stl' 'ssc simulate mesh.json --out out'
def mesh.unknown-extension 2 'cube.xyz' 'mesh with an unknown extension (.xyz)' \
  'scene mesh.json mesh.json cube.obj cube.xyz; fixture cube.obj; mv cube.obj cube.xyz' 'ssc simulate mesh.json --out out'

# ---- .sdf files ----
def sdf.truncated 2 'ball.sdf' '.sdf file cut off inside the distance values' \
  'fixture sdf.json; head -c 200 "$FIX/ball.sdf" > ball.sdf' 'ssc simulate sdf.json --out out'
def sdf.garbage 2 'ball.sdf' '.sdf file of 11 bytes of text' \
  'fixture sdf.json; echo "not an sdf" > ball.sdf' 'ssc simulate sdf.json --out out'
def sdf.bad-header 2 'ball.sdf' '.sdf header with a negative size' \
  'fixture sdf.json; printf "\x08\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\xfa\xff\xff\xff\x06\x00\x00\x00\x06\x00\x00\x00" > ball.sdf' 'ssc simulate sdf.json --out out'
def sdf.with-grid 2 'grid' 'sdf_file object with grid.resolution (the grid is the file'"'"'s)' \
  'fixture ball.sdf; scene sdf.json scene.json "\"time\"" "\"grid\": { \"resolution\": 8 }, \"time\""' "$SIM"
def sdf.rotation 2 'rotation_deg' 'sdf_file object with a rotation' \
  'fixture ball.sdf; scene sdf.json scene.json "\"position\"" "\"rotation_deg\": [0, 30, 0], \"position\""' "$SIM"

# ---- observations: PNGs and cameras.json ----
def png.garbage 2 'depth_0001.png' 'depth PNG that is a text file' \
  'obs; echo "not a png" > obs/cam0/depth_0001.png; fixture ball.json' "$GRAD"
def png.truncated 2 'depth_0001.png' 'depth PNG cut off after 100 bytes' \
  'obs; head -c 100 "$SHARED/obs/cam0/depth_0001.png" > obs/cam0/depth_0001.png; fixture ball.json' "$GRAD"
def png.wrong-size 2 'depth_0000.png && width' 'cameras.json says 32 pixels wide, the PNGs are 16' \
  'obs; edit obs/cameras.json "\"width\": 16" "\"width\": 32"; fixture ball.json' "$GRAD"
def png.huge 2 'depth_0001.png && 30000 x 30000' 'depth PNG whose header says 30000 x 30000 pixels (refused before any pixel memory is taken)' \
  'obs; printf "\x89\x50\x4e\x47\x0d\x0a\x1a\x0a\x00\x00\x00\x0d\x49\x48\x44\x52\x00\x00\x75\x30\x00\x00\x75\x30\x10\x00\x00\x00\x00\x13\xdc\x7b\x25\x00\x00\x00\x0c\x49\x44\x41\x54\x78\x9c\x63\x60\xa0\x3d\x00\x00\x00\x64\x00\x01\x86\x64\x3c\x35" > obs/cam0/depth_0001.png; fixture ball.json' "$GRAD"
def cameras.malformed 2 'cameras.json' 'cameras.json cut off in the middle' \
  'obs; head -c 150 "$SHARED/obs/cameras.json" > obs/cameras.json; fixture ball.json' "$GRAD"
def cameras.format 2 'format' 'cameras.json of an unknown format version' \
  'obs; edit obs/cameras.json ssc-depth-v1 ssc-depth-v9; fixture ball.json' "$GRAD"
def cameras.dt-zero 2 'dt' 'cameras.json with dt 0' \
  'obs; edit obs/cameras.json "\"dt\": 0.02" "\"dt\": 0.0"; fixture ball.json' "$GRAD"
def cameras.non-rigid 2 'camera_to_world' 'camera_to_world with a rotation scaled by 2' \
  'obs; edit obs/cameras.json "-1.0," "-2.0," "        1.0,
        0.0," "        2.0,
        0.0,"; fixture ball.json' "$GRAD"
def cameras.frame-times 2 'dt' 'a folder without frame_times whose frames fall between simulation steps (dt 0.03 against time.dt 0.02)' \
  'obs; edit obs/cameras.json "\"dt\": 0.02" "\"dt\": 0.03" "\"frame_times\"" "\"unused_times\""; fixture ball.json' "$GRAD"
def cameras.missing-key 2 'cameras[0].fx' 'camera without fx' \
  'obs; edit obs/cameras.json "\"fx\":" "\"focal\":"; fixture ball.json' "$GRAD"
def cameras.depth-noise 2 'depth_noise.along && ray' 'depth noise model along an unknown direction ("along": "normal")' \
  'obs; edit obs/cameras.json "\"along\": \"ray\"" "\"along\": \"normal\""; fixture ball.json' "$GRAD"
def cameras.depth-range 2 'depth_0000.png && max_depth' 'depths beyond the camera'"'"'s max_depth (max_depth 0.5 m, the ball is at 0.7 m)' \
  'obs; edit obs/cameras.json "\"max_depth\": 3.0" "\"max_depth\": 0.5"; fixture ball.json' "$GRAD"
def cameras.pattern-escape 2 'depth_pattern' 'depth_pattern that leaves the folder (../)' \
  'obs; edit obs/cameras.json "cam0/depth_" "../cam0/depth_"; fixture ball.json' "$GRAD"
def cameras.frame-times-order 2 'cameras.json && frame_times[2] && increase strictly' 'frame_times not increasing (the third frame at 0.01 s, before the second at 0.02 s)' \
  'obs; edit obs/cameras.json "0.04," "0.01,"; fixture ball.json' "$GRAD"
def cameras.frame-times-off-step 2 'cameras.json && frame_times[2] && time.dt' 'a frame time between two simulation steps (0.05 s against time.dt 0.02 s)' \
  'obs; edit obs/cameras.json "0.04," "0.05,"; fixture ball.json' "$GRAD"
def cameras.before-start 0 'warning && before t = 0' 'first_frame_time -0.04 s: the two frames before the simulation starts are left out, with a warning (also in the JSON result)' \
  'obs; edit obs/cameras.json "\"first_frame_time\": 0.0" "\"first_frame_time\": -0.04" "\"frame_times\"" "\"unused_times\""; fixture ball.json' \
  'json=$(ssc gradient ball.json --observations obs --params youngs_modulus); rc=$?; grep -q frames_before_start <<<"$json" || { echo "catalogue: the JSON result has no frames_before_start warning" >&2; exit 98; }; exit $rc'
def cameras.all-before-start 2 'obs && first_frame_time' 'first_frame_time -1 s: every frame before the simulation starts' \
  'obs; edit obs/cameras.json "\"first_frame_time\": 0.0" "\"first_frame_time\": -1.0" "\"frame_times\"" "\"unused_times\""; fixture ball.json' "$GRAD"
def note.steps-raised 0 'time.steps raised from 2 to 4' 'time.steps 2 while the observations reach step 4: raised, with a note' \
  'obs; fixture ball.json' "$GRAD"' --set time.steps=2'
def scene.no-observation 2 'observation' 'observe a scene without an observation section' \
  'fixture mesh.json cube.obj' 'ssc observe mesh.json --out out'

# ---- --set ----
def set.nan 2 'material.youngs_modulus' '--set with NaN' \
  'fixture ball.json' 'ssc simulate ball.json --out out --set material.youngs_modulus=nan'
def set.inf 2 'material.density' '--set with inf' \
  'fixture ball.json' 'ssc simulate ball.json --out out --set material.density=inf'
def set.1e400 2 'gravity.y && 1e400' '--set with 1e400 (beyond double range)' \
  'fixture ball.json' 'ssc simulate ball.json --out out --set gravity.y=1e400'
def set.no-equals 2 'material.youngs_modulus' '--set without =' \
  'fixture ball.json' 'ssc simulate ball.json --out out --set material.youngs_modulus'
def set.unknown-key 2 'material.youngs' '--set of a key the scene does not know' \
  'fixture ball.json' 'ssc simulate ball.json --out out --set material.youngs=3000'
def set.through-number 2 'material.density' '--set through a number (material.density.x=1)' \
  'fixture ball.json' 'ssc simulate ball.json --out out --set material.density.x=1'
def set.bad-json 2 'gravity' '--set with unfinished JSON [1,2' \
  'fixture ball.json' 'ssc simulate ball.json --out out --set gravity=[1,2'
def set.poisson 2 'poisson_ratio' '--set material.poisson_ratio=0.5' \
  'fixture ball.json' 'ssc simulate ball.json --out out --set material.poisson_ratio=0.5'
def set.steps 2 'time.steps' '--set time.steps=-1' \
  'fixture ball.json' 'ssc simulate ball.json --out out --set time.steps=-1'
def set.empty-component 2 '--set && material..density' '--set with an empty key component' \
  'fixture ball.json' 'ssc simulate ball.json --out out --set material..density=1'

# ---- parameter names and ranges ----
def param.other-scene 2 'result.json && the fit ran on && another body' 'residuals --params given the result.json of a fit of another scene (a larger ball; its ssc.json names the scene)' \
  'obs; fixture ball.json; ssc reconstruct ball.json --observations obs --fit youngs_modulus --starts 1 --iterations 1 --device cpu --quiet --out fit >/dev/null 2>&1; scene ball.json other.json "\"radius\": 0.1" "\"radius\": 0.12"' \
  'ssc residuals other.json --observations obs --params fit/result.json --out res'
def param.gradient-unknown 2 'youngs_modulos' 'unknown name in gradient --params' \
  'obs; fixture ball.json' 'ssc gradient ball.json --observations obs --params youngs_modulos'
def param.fit-unknown 2 'stiffnes' 'unknown name in reconstruct --fit' \
  'obs; fixture ball.json' 'ssc reconstruct ball.json --observations obs --fit stiffnes --out out'
def param.fit-duplicate 2 'youngs_modulus && twice' 'the same parameter twice in --fit' \
  'obs; fixture ball.json' 'ssc reconstruct ball.json --observations obs --fit youngs_modulus,youngs_modulus --out out'
def param.fit-duplicate-component 2 'gravity.y && twice' 'gravity and gravity.y in --fit (gravity.y twice)' \
  'obs; fixture ball.json' 'ssc reconstruct ball.json --observations obs --fit gravity,gravity.y --out out'
def param.sweep-unknown 2 'bogus' 'unknown name in sweep --param' \
  'obs; fixture ball.json' 'ssc sweep ball.json --observations obs --param bogus=1:2:3 --out out'
def param.sweep-youngs-zero 2 'youngs_modulus' 'sweep from youngs_modulus = 0 (out of range)' \
  'obs; fixture ball.json' 'ssc sweep ball.json --observations obs --param youngs_modulus=0:5000:3 --out out'
def param.sweep-vector 2 'gravity' 'sweep of a vector parameter (gravity has three components)' \
  'obs; fixture ball.json' 'ssc sweep ball.json --observations obs --param gravity=-10:-9:3 --out out'
def param.sweep-syntax 2 '--param' 'sweep --param without :N' \
  'obs; fixture ball.json' 'ssc sweep ball.json --observations obs --param youngs_modulus=1000:2000 --out out'
def param.sweep-log-negative 2 '--log' 'sweep --log over a negative range' \
  'obs; fixture ball.json' 'ssc sweep ball.json --observations obs --param gravity.y=-10:-9:3 --log --out out'
def param.sweep-baseline-truth 2 '--truth' 'sweep --cost disp without --truth' \
  'obs; fixture ball.json' 'ssc sweep ball.json --observations obs --param youngs_modulus=4000:6000:2 --cost disp --out out'
def param.fit-fd-unknown 1 'gradient' 'reconstruct --gradient bogus' \
  'obs; fixture ball.json' 'ssc reconstruct ball.json --observations obs --fit youngs_modulus --gradient bogus --out out'
def param.phi-max-negative 2 '--phi-max -1 && positive' '--phi-max -1' \
  'obs; fixture ball.json' "$GRAD"' --phi-max -1'
def param.sweep-too-many 2 '--param && 20000 && 10000' 'sweep of 20000 samples (the limit is 10000)' \
  'obs; fixture ball.json' 'ssc sweep ball.json --observations obs --param youngs_modulus=4000:6000:20000 --out out'
def diagnose.holdout-held-in 2 '--holdout 0.99 && 2 of the 5 && at least 3' 'diagnose --holdout 0.99 on 5 frames: 2 left to fit on' \
  'obs; fixture ball.json' 'ssc diagnose ball.json --observations obs --holdout 0.99 --starts 1 --iterations 1 --out out'
def diagnose.fit-candidate 2 '--fit ground.friction && candidate of the diagnosis' 'diagnose --fit ground.friction while friction is a candidate' \
  'obs; fixture ball.json' 'ssc diagnose ball.json --observations obs --fit youngs_modulus,ground.friction --holdout 0.5 --starts 1 --iterations 1 --out out'
def diagnose.iteration-limit 0 'friction: the fit stopped at the iteration limit' 'diagnose --iterations 1: the fits that stopped at the iteration limit are printed, not only kept in diagnosis.json' \
  'obs; fixture ball.json' 'ssc diagnose ball.json --observations obs --holdout 0.4 --candidates friction --starts 1 --iterations 1 --out out' writes
def probe.syntax 2 '--probe' '--probe with two numbers' \
  'fixture ball.json' 'ssc simulate ball.json --out out --probe 0,0.15'
def probe.outside 2 'probe' '--probe point outside the body' \
  'fixture ball.json' 'ssc simulate ball.json --out out --probe 5,5,5'

# ---- physically impossible starts and grids ----
def body.inside-ground 2 'ground' 'sphere that starts half inside the ground' \
  'scene ball.json scene.json "\"position\": [0, 0.15, 0]" "\"position\": [0, 0.05, 0]"' "$SIM"
def body.coarse-torus-3 2 'too coarse && grid.resolution' 'thin torus on a grid of resolution 3 (loses most of its volume)' \
  'scene torus.json scene.json "\"resolution\": 30" "\"resolution\": 3"' "$SIM"
def body.coarse-torus-2 2 'scene.json && grid.resolution' 'thin torus on a grid of resolution 2' \
  'scene torus.json scene.json "\"resolution\": 30" "\"resolution\": 2"' "$SIM"
def body.resting-start 0 'warning && ground plane 0 && thrown off && ground.planes[0].height' 'sphere placed on the ground (the soft-min contact pushes before touching): a warning with the distance it will move and the plane height of a resting start, recorded in summary.json' \
  'scene ball.json scene.json "\"position\": [0, 0.15, 0]" "\"position\": [0, 0.1, 0]"' 'ssc simulate scene.json --out out --no-frames && grep -q resting_start out/summary.json || { echo "catalogue: no resting_start warning in out/summary.json" >&2; exit 98; }' writes
def match.table 2 'ground.planes[0] && the table && segment the body' 'depth of a table patch on the ground plane left in (a resting flat box whose top is the plane, rendered with ssc observe)' \
  'fixture ball.json; ssc observe ball.json --out table --set ground.enabled=false --set gravity=[0,0,0] --set grid={\"cell_size\":0.01} --set "object={\"primitive\": \"box\", \"half_extents\": [0.12, 0.02, 0.12], \"position\": [0, -0.02, 0]}" >/dev/null 2>&1' \
  'ssc gradient ball.json --observations table --params youngs_modulus'
def match.far-away 2 'observed points' 'observations of the ball, scene moved 5 m aside (no point matches)' \
  'obs; fixture ball.json' 'ssc gradient ball.json --observations obs --set object.position=[5,0.15,0]'
def match.flipped-camera 2 'observed points' 'camera pose in OpenGL convention (looks away from the body)' \
  'obs; edit obs/cameras.json "-1.0," "1.0,"; fixture ball.json' "$GRAD"
def match.reconstruct-far 2 'observed points' 'reconstruct against observations that do not show the scene'"'"'s body' \
  'obs; fixture ball.json' 'ssc reconstruct ball.json --observations obs --fit youngs_modulus --starts 2 --iterations 2 --out out --set object.position=[5,0.15,0]'

# ---- simulations that fail ----
def sim.stiff-ground 3 'simulation failed && step' 'ground stiffness 1e12 with dt 0.02 (explodes)' \
  'scene ball.json scene.json "\"stiffness\": 100000" "\"stiffness\": 1e12" "\"steps\": 4" "\"steps\": 20"' "$SIM"
def sim.launched 3 'simulation failed && step' 'body thrown at the ground at 1e6 m/s' \
  'scene ball.json scene.json "\"linear_velocity\": [0, 0, 0]" "\"linear_velocity\": [0, -1e6, 0]"' "$SIM"
def sim.energy-gain 3 'simulation failed && gained energy' 'stiff soft-min contact (k 1e9, alpha 2e4, dt 1/600), cube dropped at 1.1 m/s' \
  'cat > scene.json <<EOF
{ "object": { "primitive": "box", "half_extents": [0.1, 0.1, 0.1], "position": [0, 0.102, 0] },
  "grid": { "resolution": 4 },
  "initial": { "linear_velocity": [0, -1.1, 0] },
  "ground": { "height": 0, "stiffness": 1e9, "softmin_alpha": 2e4 },
  "time": { "dt": 0.0016666666666666668, "steps": 40 } }
EOF' "$SIM"
def sim.solver-limit 3 'simulation failed && step && max_iterations' 'CG limited to 1 iteration per step' \
  'scene ball.json scene.json "\"time\"" "\"solver\": { \"max_iterations\": 1, \"tolerance\": 1e-12 }, \"time\""' "$SIM"

# ---- output folders ----
def out.dot 2 '--out . && working folder' '--out . (the working folder)' \
  'fixture ball.json' 'ssc simulate ball.json --out .'
def out.dotdot 2 '--out .. && working folder' '--out .. (a parent of the working folder)' \
  'fixture ball.json' 'ssc simulate ball.json --out ..'
def out.root 2 '--out / && root' '--out /' \
  'fixture ball.json' 'ssc simulate ball.json --out /'
def out.home 2 'home folder' '--out $HOME (HOME set to a scratch folder)' \
  'fixture ball.json; mkdir home; echo mine > home/precious.txt' 'HOME=$PWD/home ssc simulate ball.json --out "$PWD/home"'
def out.empty-name 2 '--out' '--out with an empty name' \
  'fixture ball.json' 'ssc simulate ball.json --out ""'
def out.file 2 'precious.txt && is a file' '--out an existing file' \
  'fixture ball.json' 'ssc simulate ball.json --out precious.txt'
def out.user-folder 2 '--out data && did not make' '--out a folder with user files and no ssc.json' \
  'fixture ball.json; mkdir data; echo mine > data/precious.txt' 'ssc simulate ball.json --out data'
def out.fake-manifest 2 '--out data && did not make' '--out a user folder whose ssc.json is not an ssc manifest' \
  'fixture ball.json; mkdir data; echo mine > data/precious.txt; echo "{\"ssc_output\": false}" > data/ssc.json' 'ssc simulate ball.json --out data'
def out.symlink 2 '--out link && symbolic link' '--out a symbolic link to an earlier ssc output' \
  'fixture ball.json; ssc simulate ball.json --out prev --no-frames 2>/dev/null && echo mine > prev/precious.txt && ln -s prev link' 'ssc simulate ball.json --out link'
def out.user-file-in-output 2 '--out prev && precious.txt && did not write' '--out an earlier ssc output into which the user put a file of their own' \
  'fixture ball.json; ssc simulate ball.json --out prev --no-frames 2>/dev/null && echo mine > prev/precious.txt' 'ssc simulate ball.json --out prev'
def out.backup-named-like-ours 0 '' 'a backup of an earlier output named like ssc'"'"'s own temporary folder is never cleaned up' \
  'fixture ball.json; ssc simulate ball.json --out prev --no-frames 2>/dev/null && cp -r prev .prev.ssc-old-99999999 && echo mine > .prev.ssc-old-99999999/precious.txt' 'ssc simulate ball.json --out prev --no-frames && test -f .prev.ssc-old-99999999/precious.txt' writes
def out.kernels-dot 2 '--out . && working folder' 'kernels --out . (every command that writes checks its --out)' \
  'fixture ball.json' 'ssc kernels ball.json --out . --no-compile'
def out.observe-user-folder 2 '--out data' 'observe --out a folder with user files' \
  'fixture ball.json; mkdir data; echo mine > data/precious.txt' 'ssc observe ball.json --out data'
def out.scene-folder 2 '--out in && in/ball.json' '--out the folder holding the scene (an earlier ssc output)' \
  'fixture ball.json; ssc simulate ball.json --out in --no-frames 2>/dev/null && mv ball.json in/ && echo mine > in/precious.txt' 'ssc simulate in/ball.json --out in'
def out.observations 2 '--out obs && holds the input' 'sweep --out the observation folder it reads' \
  'obs; fixture ball.json' 'ssc sweep ball.json --observations obs --param youngs_modulus=4000:6000:2 --out obs'
def out.observations-parent 2 '--out runs && runs/obs' 'reconstruct --out a parent of the observation folder (an earlier ssc output)' \
  'fixture ball.json; ssc simulate ball.json --out runs --no-frames 2>/dev/null && obs runs/obs' 'ssc reconstruct ball.json --observations runs/obs --fit youngs_modulus --starts 1 --iterations 1 --out runs'
def out.inside-observations 2 '--out obs/sweep && inside the input folder obs' 'sweep --out a folder inside the observation folder it reads' \
  'obs; fixture ball.json' 'ssc sweep ball.json --observations obs --param youngs_modulus=4000:6000:2 --out obs/sweep'
def out.locked 2 '--out out && another ssc run' 'a second run on an --out that a running ssc holds' \
  'fixture ball.json' 'set -m; ssc simulate ball.json --out out '"$SLOW"' 2>/dev/null & p=$!; track $p; wait_for .out.ssc-lock || exit 99; ssc simulate ball.json --out out; rc=$?; kill -TERM $p; wait $p; exit $rc'
def signal.term 143 'SIGTERM' 'simulate stopped with SIGTERM: no OUT, no .OUT.ssc-tmp-PID, no .OUT.ssc-lock left' \
  'fixture ball.json' 'set -m; ssc simulate ball.json --out out '"$SLOW"' & p=$!; track $p; wait_for .out.ssc-lock || exit 99; sleep 1; kill -TERM $p; wait $p'
def signal.int 130 'SIGINT' 'simulate stopped with SIGINT (Ctrl-C): nothing left behind' \
  'fixture ball.json' 'set -m; ssc simulate ball.json --out out '"$SLOW"' & p=$!; track $p; wait_for .out.ssc-lock || exit 99; sleep 1; kill -INT $p; wait $p'
def signal.term-replace 143 'SIGTERM' 'SIGTERM while replacing an earlier output: the earlier one stays as it was' \
  'fixture ball.json; ssc simulate ball.json --out out --no-frames 2>/dev/null' 'set -m; ssc simulate ball.json --out out '"$SLOW"' & p=$!; track $p; wait_for .out.ssc-tmp-$p || exit 99; sleep 0.5; kill -TERM $p; wait $p'
def signal.int-while-writing 130 'SIGINT' 'simulate writing frames, stopped with SIGINT 25 times at varying moments: nothing left behind any time' \
  'fixture ball.json' 'set -m; for i in $(seq 25); do ssc simulate ball.json --out out --set time.steps=1000000 2>/dev/null & p=$!; track $p; wait_for .out.ssc-tmp-$p/frames || exit 99; sleep 0.0$((i % 10)); kill -INT $p; wait $p; rc=$?; left=$(ls -A | grep -vx -e ball.json -e precious.txt); [[ $rc == 130 && -z $left ]] || { echo "catalogue: try $i: exit $rc, left: $left" >&2; exit 98; }; done; echo "interrupted by SIGINT 25 times, nothing left" >&2; exit 130'

# ---- ssc prepare: raw recordings (fixtures/recording: a 0.2 m cube thrown onto a table, Open3D layout) ----
PREP='ssc prepare rec --mesh cube.obj --fps 30 --density 300 --resolution 6 --out out'
REC='cp -r "$FIX/recording" rec; fixture cube.obj'
def prepare.no-object 2 'no object found && --scan-scale' 'prepare with a scan 8 times the object'"'"'s size: no part of the first frame matches it' \
  "$REC" "$PREP --scan-scale 1.6"
def prepare.scan-millimetres 2 'millimetres && --scan-scale 0.2' 'prepare with a scan in millimetres (a thousand times the object)' \
  "$REC" "$PREP --scan-scale 200"
def prepare.several-candidates 2 'several candidates && --pick' 'prepare on 2 frames (no static background to tell the clutter boxes from the object)' \
  "$REC" "$PREP --scan-scale 0.2 --frames 0:2"
def prepare.no-plane 2 'no plane under the object && --gravity' 'prepare with --gravity pointing down (no level plane under the object)' \
  "$REC" "$PREP --scan-scale 0.2 --gravity 0,9.81,0"
def prepare.intrinsics-size 2 '--intrinsics && principal point && 160x120' 'prepare with the intrinsics of a 640x480 camera on 160x120 images' \
  "$REC" "$PREP --scan-scale 0.2 --intrinsics 525,525,319.5,239.5"
def prepare.intrinsics-file-size 2 'intrinsic.json && 640x480 && 160x120' 'an intrinsic.json for 640x480 images beside 160x120 frames' \
  "$REC"'; edit rec/intrinsic.json "\"height\": 120" "\"height\": 480" "\"width\": 160" "\"width\": 640"' "$PREP --scan-scale 0.2"
def prepare.intrinsics-missing 2 'intrinsic.json is missing && --intrinsics' 'an Open3D recording without its intrinsic.json' \
  "$REC"'; rm rec/intrinsic.json' "$PREP --scan-scale 0.2 --format open3d"
def prepare.intrinsics-row-major 2 'intrinsic.json && intrinsic_matrix && column-major' 'an intrinsic_matrix written row-major' \
  "$REC"'; printf "{\"width\": 160, \"height\": 120, \"intrinsic_matrix\": [115, 0, 79.5, 0, 115, 59.5, 0, 0, 1]}" > rec/intrinsic.json' "$PREP --scan-scale 0.2"
def prepare.fps-missing 2 '--fps && timestamps' 'an Open3D recording (no timestamps) without --fps' \
  "$REC" 'ssc prepare rec --mesh cube.obj --scan-scale 0.2 --out out'
def prepare.depth-scale-inverted 2 '--depth-scale && 0.001' '--depth-scale 1000 (units per metre, as Open3D writes it, instead of metres per unit)' \
  "$REC" "$PREP --scan-scale 0.2 --depth-scale 1000"
def prepare.irregular-timestamps 2 'depth.txt && irregular timestamps && frames 2 and 3' 'a TUM depth.txt whose fourth frame comes half an interval late' \
  "$REC"'; printf "# timestamp filename\n0.000 depth/000000.png\n0.033 depth/000001.png\n0.066 depth/000002.png\n0.116 depth/000003.png\n0.149 depth/000004.png\n" > rec/depth.txt' \
  'ssc prepare rec --mesh cube.obj --scan-scale 0.2 --depth-scale 0.001 --density 300 --out out'
def prepare.missing-frame 2 'depth.txt && line 3 && does not exist' 'a TUM depth.txt naming a frame file that is missing' \
  "$REC"'; printf "# timestamp filename\n0.000 depth/000000.png\n0.033 depth/000007.png\n" > rec/depth.txt' \
  'ssc prepare rec --mesh cube.obj --scan-scale 0.2 --depth-scale 0.001 --density 300 --out out'
def prepare.mass-and-density 2 '--mass && --density && not both' 'prepare with both --mass and --density' \
  "$REC" "$PREP --scan-scale 0.2 --mass 2"
def prepare.scan-not-closed 0 'not closed' 'a scan with a face missing: a warning, the folder is written' \
  "$REC"'; grep -v "^f 2 7 6" cube.obj > open.obj' 'ssc prepare rec --mesh open.obj --scan-scale 0.2 --fps 30 --density 300 --resolution 6 --out out' writes

# ---- progress, notes and warnings on stderr ----
def progress.quiet 0 '' 'residuals, kernels and gradient with --quiet (and an unknown key in cameras.json): nothing on stderr, the warning only in the JSON' \
  'obs; edit obs/cameras.json "\"format\"" "\"colour\": \"red\", \"format\""; fixture ball.json' \
  'for c in "residuals ball.json --observations obs --out res" "kernels ball.json --out ker --no-compile" "gradient ball.json --observations obs --params youngs_modulus"; do err=$(ssc $c --quiet 2>&1 >/dev/null) || { echo "catalogue: ssc $c --quiet failed: $err" >&2; exit 98; }; [[ -z $err ]] || { echo "catalogue: ssc $c --quiet printed: $err" >&2; exit 98; }; done; grep -q colour res/ssc.json || { echo "catalogue: no warning in res/ssc.json" >&2; exit 98; }' writes
def progress.lines 0 'residuals: simulating && elapsed && finite differences: parameter 1/1' 'residuals and gradient --check-fd with --progress on a stderr that is not a terminal' \
  'obs; fixture ball.json' 'ssc residuals ball.json --observations obs --out res --progress >/dev/null && ssc gradient ball.json --observations obs --params youngs_modulus --check-fd --progress >/dev/null' writes
def warn.at-end 0 'warning && colour' 'a warning raised while loading is printed once, after the progress lines' \
  'obs; edit obs/cameras.json "\"format\"" "\"colour\": \"red\", \"format\""; fixture ball.json' \
  'err=$(ssc gradient ball.json --observations obs --params youngs_modulus --check-fd --progress 2>&1 >/dev/null); rc=$?; echo "$err" >&2; [[ $(grep -c colour <<<"$err") == 1 && $(tail -n 1 <<<"$err") == *colour* ]] || { echo "catalogue: the warning is not printed once, at the end" >&2; exit 98; }; exit $rc'

# ---- GPU ----
def gpu.simulate 4 'GPU error' 'simulate --device cuda without a GPU' \
  'fixture ball.json' 'ssc simulate ball.json --out out --device cuda'
def gpu.gradient 4 'GPU error' 'gradient --device cuda without a GPU' \
  'obs; fixture ball.json' 'ssc gradient ball.json --observations obs --device cuda'
def gpu.reconstruct-gpus 4 'GPU error' 'reconstruct --device cuda --gpus 2 without a GPU' \
  'obs; fixture ball.json' 'ssc reconstruct ball.json --observations obs --fit youngs_modulus --device cuda --gpus 2 --out out'

# ---- usage errors (CLI11) ----
def usage.unknown-option 1 'frobnicate' 'an option that does not exist' \
  'fixture ball.json' 'ssc simulate ball.json --out out --frobnicate'
def usage.missing-out 1 '--out' 'simulate without --out' \
  'fixture ball.json' 'ssc simulate ball.json'
def usage.missing-scene 1 'scene' 'simulate without a scene' \
  '' 'ssc simulate --out out'
def usage.no-subcommand 1 'subcommand' 'no subcommand' \
  '' 'ssc'
def usage.unknown-subcommand 1 'simulat' 'misspelt subcommand' \
  'fixture ball.json' 'ssc simulat ball.json --out out'
def usage.device 1 'device' '--device tpu' \
  'fixture ball.json' 'ssc simulate ball.json --out out --device tpu'
def usage.gpus-zero 1 'gpus' '--gpus 0' \
  'obs; fixture ball.json' 'ssc reconstruct ball.json --observations obs --fit youngs_modulus --gpus 0 --out out'
def usage.missing-fit 1 '--fit' 'reconstruct without --fit' \
  'obs; fixture ball.json' 'ssc reconstruct ball.json --observations obs --out out'
def usage.starts-not-number 1 'starts' 'reconstruct --starts abc' \
  'obs; fixture ball.json' 'ssc reconstruct ball.json --observations obs --fit youngs_modulus --starts abc --out out'
def usage.sweep-cost 1 'cost' 'sweep --cost bogus' \
  'obs; fixture ball.json' 'ssc sweep ball.json --observations obs --param youngs_modulus=4000:6000:2 --cost bogus --out out'
