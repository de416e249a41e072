"""The FMUs on every platform they carry (README "Platforms"), loaded as an importer loads them.

tests/harness/fmu_harness.c, built with each platform's C compiler, extracts nothing and knows
nothing of our FMUs: this test unzips them, turns an OSP system structure written by `master osp`
into the harness's plan (libraries, resource URIs in the platform's form, GUIDs, start values,
connections, recorded outputs), and runs the same closed loop with the linux64 libraries
natively, the win64 DLLs under wine and the AArch64 libraries (dist/linux-aarch64/) under
qemu-aarch64. The results must agree: see ``TOLERANCE``. On each platform the harness also checks
that a wrong GUID is refused and that a panic inside an FMU (fmu-core's panic probe) comes back
as fmi2Error. `make CROSS=0` builds this machine's libraries only, and these tests are skipped.
"""

import functools
import os
import pathlib
import re
import shutil
import subprocess
import warnings
import xml.etree.ElementTree as ET
import zipfile

import numpy as np
import pytest
from fmpy import read_model_description, supported_platforms

ROOT = pathlib.Path(__file__).resolve().parents[2]
DIST = ROOT / "dist"
HARNESS = ROOT / "target" / "harness"
CROSS = ROOT / "target" / "cross"

pytestmark = pytest.mark.skipif(os.environ.get("FMU_CROSS", "1") == "0", reason="make CROSS=0 builds linux64 only")

# How each platform's libraries are found and run: (FMU folder, binaries/ folder, library
# extension, harness command prefix, path of a host file as that platform sees it).
PLATFORMS = {
    "linux64": (DIST, "linux64", "so", [str(HARNESS / "linux64" / "fmu_harness")], str),
    "win64": (DIST, "win64", "dll", ["wine", str(HARNESS / "win64" / "fmu_harness.exe")], lambda p: "Z:" + str(p).replace("/", "\\")),
    "linux-aarch64": (DIST / "linux-aarch64", "linux64", "so", ["qemu-aarch64", "-L", "/usr/aarch64-linux-gnu", str(HARNESS / "linux-aarch64" / "fmu_harness")], str),
}
PROBE = {
    "linux64": CROSS / "x86_64-unknown-linux-gnu" / "release" / "examples" / "libpanic_probe.so",
    "win64": CROSS / "x86_64-pc-windows-gnu" / "release" / "examples" / "panic_probe.dll",
    "linux-aarch64": CROSS / "aarch64-unknown-linux-gnu" / "release" / "examples" / "libpanic_probe.so",
}
# The same FMUs as FMI 3.0 (dist/fmi3: one archive, a folder per platform), run by the same
# harness through fmi3Functions.h; the resources as a native path with a trailing separator.
PLATFORMS3 = {
    "linux64": (DIST / "fmi3", "x86_64-linux", "so", PLATFORMS["linux64"][3], str),
    "win64": (DIST / "fmi3", "x86_64-windows", "dll", PLATFORMS["win64"][3], PLATFORMS["win64"][4]),
    "linux-aarch64": (DIST / "fmi3", "aarch64-linux", "so", PLATFORMS["linux-aarch64"][3], str),
}
# Agreement with linux64, relative to each output's largest magnitude. Same Rust source (the win64
# and ARM builds by rustc 1.96 from Debian, linux64 by rustup's 1.95). ARM: bit for bit (glibc's
# libm on both). Windows: the road's cosines and the matrix exponential's exp come from
# MinGW's msvcrt, which may round a last bit differently. Measured 6.5e-13 at most while the
# controllers stepped in their own basis; 1.5e-11 to 1.9e-11 (CI on 24236a5, every loop of this
# file) since they step in a real Schur basis computed at instantiation, whose exponential and
# readout then carry any such last-bit difference through 10 000 steps. The stable closed loop
# does not amplify it further: 1e-10 of an output's range is still some 10⁵ roundings, far below
# anything a figure shows, and ARM stays bit for bit.
TOLERANCE = {"win64": 1e-10, "linux-aarch64": 0.0}


# Wine's own start-up, not our DLLs, once failed on a CI machine: `wineboot --init` could not map
# the shared user data page ("failed to map the shared user data: c0000018", an address conflict
# in the loader's layout, which ASLR makes a matter of chance) and then could not load kernel32.
# A fresh prefix on a fresh server is a new draw; a harness run is never retried.
WINE_ATTEMPTS = 3


def wine_server_stop(env):
    subprocess.run(["wineserver", "-k"], env=env, capture_output=True, timeout=60)


@functools.lru_cache(maxsize=None)
def wine_env(tmp: pathlib.Path):
    """The environment of a fresh wine prefix for this test session, set up and served once.

    The prefix is created by `wineboot --init` before any harness runs, and one wineserver stays
    up for the whole module (`work`'s teardown kills it; the prefix's device processes were seen
    to keep it up past its 60 s linger) instead of each harness starting its own and the next
    one connecting while that server is in its shutdown linger. A
    CI run once saw the second win64 harness exit 1 with no output at all, from the harness or
    from wine; that start-up race is the one cause we found that fits, though it never
    reproduced here. Wine prints its own errors (not its fixme/trace chatter) so that a failure
    says what wine saw. A prefix that wine itself fails to set up is thrown away and made anew,
    up to ``WINE_ATTEMPTS`` times; every failed attempt's log is reported.
    """
    failures = []
    for attempt in range(1, WINE_ATTEMPTS + 1):
        env = dict(os.environ)
        prefix = tmp / f"wineprefix-{attempt}"
        # Without the Mono/Gecko installers a fresh prefix offers.
        env.update(WINEPREFIX=str(prefix), WINEDEBUG="-all,err+all", WINEDLLOVERRIDES="mscoree,mshtml=")
        # The server and the prefix's own processes (started by wineboot) outlive these calls: they
        # write to a log file, not to pipes that a harness run would then wait on.
        log = tmp / f"wineboot-{attempt}.log"
        prefix.mkdir(parents=True, exist_ok=True)
        with open(log, "w") as out:
            for command in (["wineserver", "-p60"], ["wineboot", "--init"]):
                done = subprocess.run(command, env=env, stdout=out, stderr=out, timeout=600)
                if done.returncode != 0:
                    failures.append(f"attempt {attempt}: `{' '.join(command)}` exited {done.returncode}: {log.read_text()}")
                    break
        if len(failures) < attempt:
            if failures:
                warnings.warn("wine set up its prefix only after a retry:\n" + "\n".join(failures))
            return env
        wine_server_stop(env)
    pytest.fail(f"wine could not set up a prefix in {WINE_ATTEMPTS} attempts:\n" + "\n".join(failures))


def windows_uri(path: pathlib.Path) -> str:
    return pathlib.PureWindowsPath("Z:" + str(path).replace("/", "\\")).as_uri()


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    # A space in the path: every platform must percent-decode its resource URI.
    root = tmp_path_factory.mktemp("platforms")
    yield root / "my fmus"
    for prefix in root.glob("wineprefix-*"):  # the wineserver of wine_env, and the prefix's processes
        wine_server_stop(dict(os.environ, WINEPREFIX=str(prefix)))


def extract(fmu: pathlib.Path, into: pathlib.Path):
    with zipfile.ZipFile(fmu) as z:
        z.extractall(into)
    return read_model_description(str(fmu))


def plan(work: pathlib.Path, platform: str, scenario: str, controller: str, stop: float, fmi: int = 2,
         clocked: bool = False):
    """The harness plan of `master osp`'s system for `platform` in FMI version `fmi`, and the
    recorded column names; `clocked`: the FMI 3.0 controller in Event Mode, ticked by its clock."""
    fmu_dir, folder, ext, _, host_path = (PLATFORMS3 if fmi == 3 else PLATFORMS)[platform]
    structure = work / f"{scenario}-{controller}.xml"
    if not structure.exists():
        work.mkdir(parents=True, exist_ok=True)
        subprocess.run([str(ROOT / "target" / "release" / "master"), "osp", "--scenario", str(ROOT / "scenarios" / f"{scenario}.json"),
                        "--controller", controller, "--out", str(structure)], check=True, capture_output=True)
    ns = {"o": "http://opensimulationplatform.com/MSMI/OSPSystemStructure"}
    root = ET.parse(structure).getroot()
    lines, index, variables, columns = [f"fmi\t{fmi}"], {}, {}, []
    step = float(root.find("o:BaseStepSize", ns).text)
    for i, sim in enumerate(root.find("o:Simulators", ns)):
        name, source = sim.get("name"), sim.get("source")
        unpacked = work / f"{platform}-fmi{fmi}" / name
        md = extract(fmu_dir / source, unpacked)
        library = unpacked / "binaries" / folder / f"{md.coSimulation.modelIdentifier}.{ext}"
        resources = unpacked / "resources"
        if fmi == 3:  # FMI 3.0: an absolute native path ending in a separator
            uri = host_path(resources) + ("\\" if platform == "win64" else "/")
        else:
            uri = windows_uri(resources) if platform == "win64" else resources.as_uri()
        lines.append(f"fmu\t{name}\t{host_path(library)}\t{uri}\t{md.guid}")
        index[name] = i
        variables[name] = {v.name: v for v in md.modelVariables}
        for value in sim.iter("{%s}InitialValue" % ns["o"]):
            typed = value[0]
            kind = {"Real": "real", "Integer": "integer"}[typed.tag.split("}")[1]]
            lines.append(f"{kind}\t{i}\t{variables[name][value.get('variable')].valueReference}\t{typed.get('value')}")
    for conn in root.iter("{%s}VariableConnection" % ns["o"]):
        (a, b) = conn.findall("o:Variable", ns)
        va = variables[a.get("simulator")][a.get("name")]
        vb = variables[b.get("simulator")][b.get("name")]
        lines.append(f"connect\t{index[a.get('simulator')]}\t{va.valueReference}\t{index[b.get('simulator')]}\t{vb.valueReference}")
    for name in ("plant", controller):
        for v in variables[name].values():
            if v.causality == "output" and v.type in ("Real", "Float64"):
                lines.append(f"record\t{index[name]}\t{v.valueReference}\t{name}.{v.name}")
                columns.append(f"{name}.{v.name}")
    if clocked:
        [clock] = [v for v in variables[controller].values() if v.type == "Clock"]
        lines.append(f"clock\t{index[controller]}\t{clock.valueReference}")
    lines.append(f"time\t{step!r}\t{stop!r}")
    tag = "-clocked" if clocked else ""
    path = work / f"{platform}-fmi{fmi}-{scenario}-{controller}{tag}.plan"
    path.write_text("\n".join(lines) + "\n")
    return path, columns


def run_harness(work, platform, *args):
    command = PLATFORMS[platform][3]
    shutil.which(command[0]) or pytest.fail(f"{command[0]} not found: `make` installs it (CROSS=1)")
    env = wine_env(work.parent) if platform == "win64" else None
    done = subprocess.run(command + list(args), capture_output=True, text=True, env=env, timeout=600)
    assert done.returncode == 0, f"{platform}: {done.stdout}\n{done.stderr}"
    return done


@functools.lru_cache(maxsize=None)
def closed_loop(work, platform, scenario, controller, stop, fmi=2, clocked=False):
    """The harness's log on `platform`; linux64's, the reference, is run once per scenario."""
    path, columns = plan(work, platform, scenario, controller, stop, fmi, clocked)
    out = work / f"{platform}-fmi{fmi}-{scenario}-{controller}{'-clocked' if clocked else ''}.csv"
    run_harness(work, platform, "run", PLATFORMS[platform][4](path), PLATFORMS[platform][4](out))
    data = np.genfromtxt(out, delimiter=",", names=True, deletechars="")
    assert list(data.dtype.names) == ["time"] + columns
    return data


@pytest.mark.parametrize("scenario,controller,stop", [("iso_c", "hinf_of", 3.0), ("fault", "ft_of", 3.0)])
@pytest.mark.parametrize("platform", ["win64", "linux-aarch64"])
def test_each_platform_runs_the_closed_loop_like_linux64(work, platform, scenario, controller, stop):
    reference = closed_loop(work, "linux64", scenario, controller, stop)
    other = closed_loop(work, platform, scenario, controller, stop)
    assert len(reference) == len(other) == round(stop / 1e-3)
    # The loop really ran: a class C road shakes the seat, the controller pushes.
    assert np.sqrt(np.mean(reference["plant.a_seat"] ** 2)) > 0.005
    assert np.max(np.abs(reference["plant.f_fl"])) > 10.0
    worst = 0.0
    for name in reference.dtype.names[1:]:
        scale = max(np.max(np.abs(reference[name])), 1e-12)
        error = np.max(np.abs(other[name] - reference[name])) / scale
        worst = max(worst, error)
        assert error <= TOLERANCE[platform], f"{platform} {scenario}/{controller}: {name} differs by {error:.2e} of its range"
    print(f"{platform} {scenario}/{controller}: largest difference {worst:.2e} of an output's range")


@pytest.mark.parametrize("scenario,controller,stop", [("iso_c", "hinf_of", 3.0), ("fault", "ft_of", 3.0)])
@pytest.mark.parametrize("platform", list(PLATFORMS3))
def test_each_platform_runs_the_fmi3_loop_like_the_fmi2_loop(work, platform, scenario, controller, stop):
    """The same loop through fmi3Functions.h on each platform: against linux64's FMI 2.0 run, bit
    for bit on Linux (one library serves both versions), within the platform's tolerance on
    Windows."""
    reference = closed_loop(work, "linux64", scenario, controller, stop)
    other = closed_loop(work, platform, scenario, controller, stop, 3)
    assert len(reference) == len(other) == round(stop / 1e-3)
    assert reference.dtype.names == other.dtype.names
    for name in reference.dtype.names[1:]:
        scale = max(np.max(np.abs(reference[name])), 1e-12)
        error = np.max(np.abs(other[name] - reference[name])) / scale
        assert error <= TOLERANCE.get(platform, 0.0), f"FMI 3.0 on {platform} {scenario}/{controller}: {name} differs by {error:.2e} of its range"


@pytest.mark.parametrize("platform", list(PLATFORMS3))
def test_each_platform_ticks_a_clocked_controller_like_linux64(work, platform):
    """`hinf_sf` in Event Mode through fmi3Functions.h, its sample clock ticked by the harness
    before each of its steps (fmi3EnterEventMode, fmi3SetClock, fmi3UpdateDiscreteStates,
    fmi3EnterStepMode; every call checked, every step asking for Event Mode at its end): on
    linux64 a loop of its own (the command computed at the tick is held over the step, where
    the step path's is the one after it) within 5 % of the unclocked one's seat acceleration;
    elsewhere linux64's, bit for bit on ARM and within the platform's tolerance on Windows."""
    args = ("iso_c", "hinf_sf", 3.0, 3)
    reference = closed_loop(work, "linux64", *args, clocked=True)
    rms = lambda log: np.sqrt(np.mean(log["plant.a_seat"] ** 2))
    if platform == "linux64":
        unclocked = closed_loop(work, "linux64", *args)
        assert not np.array_equal(reference["plant.a_seat"], unclocked["plant.a_seat"])
        assert abs(rms(reference) / rms(unclocked) - 1) < 0.05, (rms(reference), rms(unclocked))
        print(f"RMS a_seat: clocked {rms(reference):.5f}, step path {rms(unclocked):.5f} m/s2")
        return
    other = closed_loop(work, platform, *args, clocked=True)
    assert len(other) == len(reference) == 3000
    for name in reference.dtype.names[1:]:
        scale = max(np.max(np.abs(reference[name])), 1e-12)
        error = np.max(np.abs(other[name] - reference[name])) / scale
        assert error <= TOLERANCE.get(platform, 0.0), f"clocked on {platform}: {name} differs by {error:.2e} of its range"


@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize("platform", list(PLATFORMS))
def test_a_panic_in_the_fmu_is_an_error_on_every_platform(work, platform, fmi):
    host_probe = PROBE["linux64"]  # loads here: fmu-pack asks it for its description
    xml = work / "probe.xml"
    work.mkdir(parents=True, exist_ok=True)
    subprocess.run([str(ROOT / "target" / "release" / "fmu-pack"), "description", "--lib", str(host_probe), "--xml", str(xml)],
                   check=True, capture_output=True)
    description = ET.parse(xml).getroot()
    guid = description.get("guid")
    u = next(v for v in description.iter("ScalarVariable") if v.get("name") == "u").get("valueReference")
    library = PROBE[platform]
    assert library.exists(), f"{library}: `make` builds it (CROSS=1)"
    done = run_harness(work, platform, "panic", PLATFORMS[platform][4](library), guid, u, *(["3"] if fmi == 3 else []))
    assert f"panic -> fmi{fmi}Error" in done.stdout
    assert "internal error: the probe panics on u = 666" in done.stderr
    mismatch = "instantiation token mismatch" if fmi == 3 else "GUID mismatch"
    assert mismatch in done.stderr, "the wrong GUID was refused with a message"


def test_every_fmu_carries_its_platforms():
    for fmu in sorted(DIST.glob("*.fmu")):
        assert supported_platforms(str(fmu)) == ["linux64", "win64"], fmu
    arm = sorted((DIST / "linux-aarch64").glob("*.fmu"))
    assert [f.name for f in arm] == [f.name for f in sorted(DIST.glob("*.fmu"))]
    for fmu in arm:
        with zipfile.ZipFile(fmu) as z:
            libs = [n for n in z.namelist() if n.startswith("binaries/") and not n.endswith("/")]
            assert len(libs) == 1 and libs[0].startswith("binaries/linux64/"), (fmu, libs)
            elf = z.read(libs[0])
        assert elf[:4] == b"\x7fELF" and int.from_bytes(elf[18:20], "little") == 183, f"{fmu}: not an AArch64 ELF"
        # The same model: the description is byte-identical to the x86-64 FMU's.
        with zipfile.ZipFile(DIST / fmu.name) as z, zipfile.ZipFile(fmu) as a:
            assert z.read("modelDescription.xml") == a.read("modelDescription.xml")


def test_every_fmi3_fmu_carries_every_platform_in_one_archive():
    """FMI 3.0 names a folder per architecture: each archive of dist/fmi3 holds the x86-64 Linux,
    x86-64 Windows and AArch64 Linux libraries, byte for byte those of the FMI 2.0 archives (one
    library serves both versions)."""
    fmi3 = sorted((DIST / "fmi3").glob("*.fmu"))
    assert [f.name for f in fmi3] == [f.name for f in sorted(DIST.glob("*.fmu"))]
    for fmu in fmi3:
        stem = fmu.stem
        with zipfile.ZipFile(fmu) as z, zipfile.ZipFile(DIST / fmu.name) as two, \
                zipfile.ZipFile(DIST / "linux-aarch64" / fmu.name) as arm:
            folders = sorted({n.split("/")[1] for n in z.namelist() if n.startswith("binaries/") and n.count("/") == 2})
            assert folders == ["aarch64-linux", "x86_64-linux", "x86_64-windows"], (stem, folders)
            identifier = read_model_description(str(fmu)).coSimulation.modelIdentifier
            assert z.read(f"binaries/x86_64-linux/{identifier}.so") == two.read(f"binaries/linux64/{identifier}.so"), stem
            assert z.read(f"binaries/x86_64-windows/{identifier}.dll") == two.read(f"binaries/win64/{identifier}.dll"), stem
            assert z.read(f"binaries/aarch64-linux/{identifier}.so") == arm.read(f"binaries/linux64/{identifier}.so"), stem


def test_readme_states_the_platforms_the_fmus_carry():
    table = subprocess.run([str(ROOT / "target" / "release" / "fmu-pack"), "platforms", "--fmu", "dist/plant.fmu",
                            "--fmu", "dist/linux-aarch64/plant.fmu"], cwd=ROOT, check=True, capture_output=True, text=True).stdout
    readme = (ROOT / "README.md").read_text()
    assert f"<!-- platform:begin -->\n{table}<!-- platform:end -->" in readme, \
        "README.md states other platforms than dist/ carries: run `make descriptions`"
    # What the table promises: glibc 2.17 on both Linux builds, no MinGW runtime DLL on Windows.
    rows = re.findall(r"\| `[^|]*` \| `linux64` \|[^\n]*", table)
    assert len(rows) == 2, table
    for row in rows:
        major, minor = map(int, re.search(r"glibc ≥ (\d+)\.(\d+):", row).groups())
        assert (major, minor) <= (2, 17), row
    win = re.search(r"\| `win64` \|[^\n]*", table).group(0)
    assert "imports only" in win and not re.search(r"\blib\w*\.dll", win, re.I), win
