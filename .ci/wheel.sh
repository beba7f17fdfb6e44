#!/usr/bin/env bash
# Build the release wheel (one abi3 wheel, manylinux2014), install it into a fresh venv with
# no Rust toolchain on PATH, and smoke-test every subcommand from it.
# Run from the repository root after the test command (CI: .ci/run).
set -euo pipefail
cd "$(dirname "$0")/.."
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

echo "== wheel: build (maturin --zig, manylinux2014, abi3)"
python -m venv "$work/build"
"$work/build/bin/pip" install -q "maturin>=1.9.4,<2" "ziglang>=0.13"
# maturin finds zig as `python -m ziglang`: the build venv's python must come first.
(
    export PATH="$work/build/bin:$PATH"
    maturin build --release --zig --compatibility manylinux2014 --out "$work/dist" --quiet
)
ls "$work/dist"
wheels=("$work"/dist/*.whl)
if [ "${#wheels[@]}" -ne 1 ]; then
    echo "expected exactly one wheel, got ${#wheels[@]}" >&2
    exit 1
fi
wheel="${wheels[0]}"
case "$(basename "$wheel")" in
    splitlf-*-cp310-abi3-manylinux2014_x86_64*.whl | splitlf-*-cp310-abi3-manylinux_2_17_x86_64*.whl) ;;
    *) echo "unexpected wheel tag: $(basename "$wheel")" >&2; exit 1 ;;
esac
# The extension may need no glibc symbol newer than manylinux2014's 2.17.
python - "$wheel" <<'PY'
import re, subprocess, sys, tempfile, zipfile
with tempfile.TemporaryDirectory() as d:
    z = zipfile.ZipFile(sys.argv[1])
    so = [n for n in z.namelist() if n.endswith(".so")]
    assert len(so) == 1 and so[0].endswith(".abi3.so"), so
    path = z.extract(so[0], d)
    out = subprocess.run(["objdump", "-T", path], capture_output=True, text=True,
                         check=True).stdout
vers = {tuple(map(int, v.split("."))) for v in re.findall(r"GLIBC_([0-9.]+)", out)}
newest = max(vers)
print("newest glibc symbol version:", ".".join(map(str, newest)))
assert newest <= (2, 17), newest
PY

echo "== wheel: install into a fresh venv without Rust"
python -m venv "$work/user"
"$work/user/bin/pip" install -q "${wheel}[all]"
(
    export PATH="$work/user/bin:/usr/local/bin:/usr/bin:/bin"
    unset CARGO_HOME RUSTUP_HOME
    if command -v cargo >/dev/null || command -v rustc >/dev/null; then
        echo "a Rust toolchain is still on PATH" >&2
        exit 1
    fi
    cd "$work"
    set -x
    splitlf --help >/dev/null
    splitlf report
    splitlf report --json > report.json
    python -c "import json, splitlf; d = json.load(open('report.json')); print('version', splitlf.__version__)"
    splitlf figures --out figs --dpi 60
    ls figs
    splitlf trace --out trace.npz
    splitlf trace --out trace-json.npz --json > trace.json
    ! splitlf trace --out trace.npz 2>refused.txt   # an existing output is never overwritten
    grep -q -- '--force' refused.txt
    splitlf trace --out trace.npz --force
    printf '[grid]\nD = [10.0, 20.0]\n[depths]\nmin = 150.0\nmax = 10000.0\nnum = 20\n' > sweep.toml
    splitlf sweep --grid sweep.toml --json > sweep.json
    splitlf sweep --grid sweep.toml --out sweep.nc
    splitlf simulate --z 642 --texture sinusoid:2 --json > sim.json
    python -c "import json; [json.load(open(f)) for f in ('report.json', 'trace.json', 'sweep.json', 'sim.json')]"
    splitlf explore --help >/dev/null
    python -c "import urllib.request; from splitlf.explorer import serve; s = serve(threaded=True); assert urllib.request.urlopen(s.url, timeout=60).status == 200; s.stop()"
)
echo "== wheel: ok"
