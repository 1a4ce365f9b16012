#!/usr/bin/env bash
# The installed package used from a folder with no source tree: the source tree (with the build
# tree in it) is hidden under an empty read-only folder in a mount namespace of its own, and the
# commands run with a clean environment (PATH=/usr/bin:/bin, no PYTHONPATH): `sirupp demo` runs
# its 7 movement sets, `sirupp class check` accepts a class file naming installed data only,
# /usr/bin/python3 imports the module, a course notebook runs, and the installed example
# controller builds with g++ against /usr/include/sirupp/controller.h and with `sirupp controller
# build` in the sandbox.
set -u
source "$(dirname "$0")/lib.sh"
root=$(cd "$(dirname "$0")/../.." && pwd)
work=$(mktemp -d /tmp/sirupp-package-use.XXXXXX)
trap 'rm -rf "$work"' EXIT
chmod 755 "$work"

cat >"$work/steps.sh" <<'STEPS'
set -u
cd "$1"
fail=0
[[ ! -e "$2/CMakeLists.txt" ]] || { echo "FAIL: the source tree is visible"; fail=1; }
t=$(date +%s)
sirupp demo --out demo >demo.out 2>&1
rc=$?
n=$(grep -c "done in" demo.out)
if [[ $rc -ne 0 || $n -ne 7 ]] || ! grep -q "(7/7)" demo.out || ! grep -q "^demo: done" demo.out; then
  echo "FAIL sirupp demo: exit $rc, $n of 7 sets done"; fail=1
  sed -n '/running 7 movement sets/,/Table II/p' demo.out | head -60
  tail -3 demo.out; uptime
  # What the processes said about stalls and losses (docs/timing.md, "The demo on a loaded PC").
  grep -h "lost\|no answer\|behind the wall\|stopped at tick" demo/logs/*.log | tail -12
else
  echo "sirupp demo: 7/7 sets in $(( $(date +%s) - t )) s"
fi
grep -q "/usr/share/sirupp/config/labs/demo.yaml" demo.out || { echo "FAIL demo: not the installed layout"; head -5 demo.out; fail=1; }

cat >class.yaml <<YAML
class: installed-check
robot: config/robots/puma260.yaml
students: [alice, bob]
data: class-data
grading: {suite: config/grading/basic.yaml}
YAML
sirupp class check class.yaml >check.out 2>&1 || { echo "FAIL sirupp class check"; cat check.out; fail=1; }

/usr/bin/python3 - <<'PY' || fail=1
import sirupp
assert sirupp.__file__.startswith("/usr/lib/python3/dist-packages/sirupp/"), sirupp.__file__
path = sirupp.data_path("config/robots/puma260.yaml")
assert path == "/usr/share/sirupp/config/robots/puma260.yaml", path
m = sirupp.Model(path)
print("python3: import sirupp from", sirupp.__file__, "; fkine(home) z =", round(float(m.fkine(m.home)[2][3]), 5))
PY

cp /usr/share/sirupp/notebooks/01_forward_kinematics.ipynb nb.ipynb
MPLBACKEND=Agg /usr/bin/python3 - <<'PY' || fail=1
import nbformat
from nbclient import NotebookClient
nb = nbformat.read("nb.ipynb", as_version=4)
NotebookClient(nb, timeout=300, kernel_name="python3", resources={"metadata": {"path": "."}}).execute()
errors = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs if o.output_type == "error"]
assert not errors, errors
print("notebook 01_forward_kinematics: ran,", sum(c.cell_type == "code" for c in nb.cells), "code cells")
PY

g++ -std=c++17 -O2 -shared -fPIC /usr/share/sirupp/examples/02_pd_gravity/pd_gravity.cpp -o pd_gravity.so ||
  { echo "FAIL g++ on the installed example"; fail=1; }
# The same source through `sirupp controller build`: the header from /usr/share/sirupp, g++ in the
# sandbox (its own uid as root: the folder must be readable).
cp /usr/share/sirupp/examples/02_pd_gravity/pd_gravity.cpp student.cpp
sirupp controller build student.cpp --out built >build.out 2>&1 && [[ -s built/student.so ]] ||
  { echo "FAIL sirupp controller build"; cat build.out; fail=1; }
exit $fail
STEPS

t=$(now)
# The mount namespace: an empty read-only folder over the source tree.
unshare --mount --propagation private -- /bin/sh -c \
  "mount -t tmpfs -o ro,mode=0755 sirupp-hidden '$root' && exec env -i PATH=/usr/bin:/bin HOME='$work' LANG=C.UTF-8 PYDEVD_DISABLE_FILE_VALIDATION=1 bash '$work/steps.sh' '$work' '$root'"
rc=$?
[[ $rc -eq 0 ]] || fail=1
finish package_use "$(since "$t") s"
