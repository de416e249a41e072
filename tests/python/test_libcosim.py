"""The closed loop in libcosim (the Open Simulation Platform's co-simulation library, through
libcosimpy from PyPI), loaded from the OSP system structure `make` writes beside the FMUs
(dist/OspSystemStructure.xml: road, plant and hinf_of on the bump), against the Rust master on
the same scenario. libcosim's fixed-step algorithm exchanges values after all simulators have
stepped (Jacobi), the master in Gauss-Seidel order, so the two differ by the one-step lag of the
controller loop: compared to 3 % in RMS and peak, and by correlation."""

import pathlib
import subprocess

import numpy as np
from libcosimpy.CosimEnums import CosimVariableType
from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
from libcosimpy.CosimObserver import CosimObserver

import master_csv

ROOT = pathlib.Path(__file__).resolve().parents[2]


def test_libcosim_runs_the_osp_system_structure_like_the_rust_master(tmp_path):
    log_output_level(CosimLogLevel.ERROR)
    structure = ROOT / "dist" / "OspSystemStructure.xml"
    assert structure.exists(), "run `make` (it writes dist/OspSystemStructure.xml)"
    ex = CosimExecution.from_osp_config_file(osp_path=str(structure))
    observer = CosimObserver.create_time_series()
    ex.add_observer(observer=observer)
    plant = ex.slave_index_from_instance_name("plant")
    refs = {v.name.decode(): v.reference for v in ex.slave_variables(slave_index=plant)}
    for name in ("a_seat", "stroke_fl"):
        observer.start_time_series(plant, value_reference=refs[name], variable_type=CosimVariableType.REAL)
    assert ex.simulate_until(target_time=int(4e9))
    cosim = {}
    for name in ("a_seat", "stroke_fl"):
        _, _, values = observer.time_series_real_samples(slave_index=plant, value_reference=refs[name], from_step=1, sample_count=4000)
        cosim[name] = np.array(values)

    out = tmp_path / "bump.csv"
    subprocess.run([str(ROOT / "target" / "release" / "master"), "--dist", str(ROOT / "dist"), "run", "--scenario",
                    str(ROOT / "scenarios" / "bump.json"), "--controller", "hinf_of", "--out", str(out)], check=True)
    rust = master_csv.read(out)
    for name in ("a_seat", "stroke_fl"):
        a, b = cosim[name], rust[name][: len(cosim[name])]
        rms_a, rms_b = np.sqrt(np.mean(a ** 2)), np.sqrt(np.mean(b ** 2))
        print(name, "libcosim RMS", rms_a, "master RMS", rms_b, "peaks", np.abs(a).max(), np.abs(b).max(), "corr", np.corrcoef(a, b)[0, 1])
        assert len(a) >= 3990
        assert abs(rms_a / rms_b - 1) < 0.03 and abs(np.abs(a).max() / np.abs(b).max() - 1) < 0.03
        assert np.corrcoef(a, b)[0, 1] > 0.99
