"""`make bench-floor`: how fast the closed loop of `make bench` could be if the FMUs' dense
products cost nothing, and the loop target restated against it (issue 49): the shipped loop
within 1.3x of this floor on both roads. (The old targets, 50x FMPy and 1000x real time, were
below the floor itself.)

The working tree's sources are copied to a temporary directory and one function is changed:
`linsys::exact::mat_vec_sum` (and its variant for a quasi-triangular first matrix,
`mat_vec_sum_quasi_upper`) becomes a copy of its first vector's head, halved. Those functions are
every dense matrix–vector product of the FMUs' stepping: the plant's step (the car and the
vibration meter, `Φ x + Γ₀ v₀ + Γ₁ Δv`) and the controller's step and outputs.
Everything else is as shipped: the FMI calls, their checks, the state machine, the plant's
sparse output rows and bookkeeping, the road, the master, and the first step's discretisations
(matrix exponentials). The three FMUs are built from that copy (into target/floor, kept between
runs), packed with `dist/hinf_of`'s resources, and run by the same master, scenarios and
best-of-three timing as `bench/master_vs_fmpy.py`, beside the shipped FMUs and FMPy. The states
then decay instead of following the car, but the loop makes the same calls and each plant step
the same single piece (no delay, fault or command ramp on these roads), so only the products'
cost is gone. A 200 s run divided by 20 leaves out each run's one-off costs."""

import os
import pathlib
import shutil
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))
import master_vs_fmpy as bench  # noqa: E402

# Every dense product: the general one and the one whose first matrix is quasi-upper-triangular
# (a controller stepped in its real Schur basis).
SIGNATURES = [f"pub fn {name}(y: &mut [f64], terms: &[(&DMatrix<f64>, &[f64])]) {{\n"
              for name in ("mat_vec_sum", "mat_vec_sum_quasi_upper")]
FREE = ("    if std::hint::black_box(true) {\n"
        "        y.iter_mut().zip(terms[0].1).for_each(|(y, x)| *y = 0.5 * x);\n"
        "        return;\n"
        "    }\n")


def floor_dist(work):
    """dist/ with plant, road and hinf_of built from the sources with free products."""
    src = work / "src"
    files = subprocess.run(["git", "-C", str(ROOT), "ls-files", "-z"], check=True, capture_output=True).stdout
    for name in filter(None, files.decode().split("\0")):
        if (ROOT / name).is_file():
            (src / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / name, src / name)
    exact = src / "linsys" / "src" / "exact.rs"
    text = exact.read_text()
    for signature in SIGNATURES:
        if text.count(signature) != 1:
            sys.exit(f"{exact.relative_to(src)}: no '{signature.strip()}'; update bench/floor.py")
        text = text.replace(signature, signature + FREE)
    exact.write_text(text)
    target = ROOT / "target" / "floor"
    subprocess.run(["cargo", "build", "--release", "-q", "-p", "fmu-plant", "-p", "fmu-road", "-p", "fmu-controller"],
                   cwd=src, check=True, env={**os.environ, "CARGO_TARGET_DIR": str(target)})
    dist = work / "dist"
    dist.mkdir()
    for fmu, extra in (("plant", []), ("road", []), ("controller", ["--resources", str(ROOT / "dist" / "hinf_of")])):
        name = "hinf_of" if fmu == "controller" else fmu
        subprocess.run([str(ROOT / "target" / "release" / "fmu-pack"), "fmu", "--lib", str(target / "release" / f"libfmu_{fmu}.so"),
                        *extra, "--out", str(dist / f"{name}.fmu")], check=True, capture_output=True)
    return dist


def main():
    long = 200.0
    with tempfile.TemporaryDirectory() as tmp:
        floor = floor_dist(pathlib.Path(tmp))
        seconds = bench.SECONDS
        # (scenario file, factor to the loop time per `seconds` simulated)
        runs = [(bench.scenario_file(name, duration)[1], seconds / duration)
                for name in ("bump", "iso_c") for duration in (seconds, long)]
        fmpy = bench.python(bench.scenario_file("bump")[0]["road"])
        rows = [(name, [bench.rust(scenario, dist) * per_run for scenario, per_run in runs])
                for name, dist in (("as shipped (dist/)", ROOT / "dist"), ("every product free", floor))]
    print(f"A closed loop at 1 kHz (road -> plant -> hinf_of), loop time per 10 s simulated, best of three: a 10 s run, and a "
          f"{long:.0f} s run / {long / seconds:.0f} (no first step's discretisations, warm caches); FMPy {fmpy * 1e3:.0f} ms on the 10 s bump")
    print("| FMUs | bump, 10 s [ms] | faster than FMPy | bump, 200 s / 20 [ms] | ISO class C, 10 s [ms] | real time | ISO class C, 200 s / 20 [ms] |")
    print("|---|---|---|---|---|---|---|")
    for name, (b, b_long, i, i_long) in rows:
        print(f"| {name} | {b * 1e3:.1f} | {fmpy / b:.0f}x | {b_long * 1e3:.1f} | {i * 1e3:.1f} | {seconds / i:.0f}x | {i_long * 1e3:.1f} |")
    (shipped, floor_times) = (rows[0][1], rows[1][1])
    ratio = [a / b for a, b in zip(shipped, floor_times)]
    print(f"| shipped / floor (target at most 1.3) | {ratio[0]:.2f} | | {ratio[1]:.2f} | {ratio[2]:.2f} | | {ratio[3]:.2f} |")


if __name__ == "__main__":
    main()
