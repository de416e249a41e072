"""What a user or a packager reads about the project agrees with itself: the licence files the
Cargo manifest names exist, CITATION.cff is valid CFF 1.2.0 and names the version every FMU
reports (`version`, and `generationTool` with it), the changelog has that version, the README's
comparison is the one `make` measures, and the Makefile builds every variant synth knows."""
import json
import math
import re
import subprocess
import zipfile
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
VENV_BIN = Path(__file__).resolve().parents[2] / ".venv" / "bin"


def crate_version(crate):
    text = (ROOT / crate / "Cargo.toml").read_text()
    return re.search(r'^version = "([^"]+)"', text, re.M).group(1)


def test_licence_files_match_the_manifest():
    manifest = (ROOT / "Cargo.toml").read_text()
    assert 'license = "MIT OR Apache-2.0"' in manifest
    assert "Permission is hereby granted, free of charge" in (ROOT / "LICENSE-MIT").read_text()
    assert "Apache License" in (ROOT / "LICENSE-APACHE").read_text()


def test_citation_is_valid_and_every_fmu_reports_its_version():
    version = crate_version("fmu-core")
    result = subprocess.run([str(VENV_BIN / "cffconvert"), "--validate", "-i", str(ROOT / "CITATION.cff")],
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr
    assert re.search(rf"^version: {re.escape(version)}$", (ROOT / "CITATION.cff").read_text(), re.M)
    assert f"## [{version}]" in (ROOT / "CHANGELOG.md").read_text()
    fmus = sorted((ROOT / "dist").glob("*.fmu"))
    assert len(fmus) >= 9
    for fmu in fmus:
        with zipfile.ZipFile(fmu) as z:
            root = ET.fromstring(z.read("modelDescription.xml"))
        assert root.get("generationTool") == f"suspension-fmus {version} (fmu-core)", fmu.name
        assert root.get("version").split("+")[0] == version, fmu.name


def block(text, tag):
    return text.split(f"<!-- {tag}:begin -->\n")[1].split(f"<!-- {tag}:end -->")[0]


def without_timing(table):
    """The table without its wall-time line, which differs from run to run."""
    return "\n".join(line for line in table.splitlines() if not re.match(r"^\d+ runs in [\d.]+ s", line))


@pytest.mark.parametrize("heading,tag", [("## Summary: W_k RMS seat acceleration [m/s²]", "comparison"),
                                         ("## Limits and model validity", "limits")])
def test_the_readme_comparison_is_the_measured_one(heading, tag):
    """`make test` runs `master compare` first (results/report.md); `make readme` splices its
    summary and the runs it flags into the README. The figures are deterministic to the digits
    printed."""
    report = (ROOT / "results" / "report.md").read_text()
    section = report.split(heading + "\n")[1].split("\n## ")[0]
    readme = block((ROOT / "README.md").read_text(), tag)
    assert without_timing(readme).strip() == without_timing(section).strip(), f"README {tag} is stale: run `make readme`"


@pytest.mark.parametrize("tag,path", [("modes", "dist/car.md"), ("gamma", "dist/thesis/gamma.md")])
def test_the_readme_blocks_are_what_synth_writes(tag, path):
    """`synth` writes the modes of the car it designs for (dist/car.md) and, on the thesis's design
    file, what γ says about comfort (dist/thesis/gamma.md: each design's certified norm beside the
    passive car's on the same plant, and the comfort predicted beside the passive car's);
    `make readme` splices them."""
    written = (ROOT / path).read_text()
    assert block((ROOT / "README.md").read_text(), tag).strip() == written.strip(), f"README {tag} is stale: run `make readme`"


def test_what_the_readme_says_around_the_gamma_figures_holds_on_every_thesis_certificate():
    """Every thesis design's norm peaks at the wheel hop (11.6 Hz on this car) and is pinned within
    10 % of the passive car's on the same plant (README "Why not γ")."""
    assert "passive car scores" in (ROOT / "dist" / "thesis" / "gamma.md").read_text()
    for cert in sorted((ROOT / "dist" / "thesis").glob("*.certificate.json")):
        c = json.loads(cert.read_text())
        assert 10.0 < c["peak_frequency_rad_s"] / (2 * math.pi) < 12.0, cert.name
        assert 0.9 * c["passive_norm"] < c["norm_upper"] <= c["passive_norm"] * (1 + 1e-6), cert.name


def test_the_makefile_builds_every_variant_synth_lists():
    listed = subprocess.run([str(ROOT / "target" / "release" / "synth"), "--list"], capture_output=True, text=True, check=True).stdout.split()
    line = re.search(r"^CONTROLLERS := (.*)$", (ROOT / "Makefile").read_text(), re.M).group(1)
    assert line.split() == listed
