"""The <ModelStructure> of the shipped FMUs, read by FMPy as an importer reads it.

An importer that orders a coupled system's equations (OMSimulator, a master with an algebraic-loop
check) builds a graph from these lists: connected variables plus each unknown's dependencies. With
no `dependencies` on the InitialUnknowns it must assume every output depends on every input, and
road -> plant -> controller -> plant looks like an algebraic loop. Here each controller is wired to
the plant as the master wires it and both graphs (communication points, initialisation) must be
acyclic; the dependencies must name only knowns the standard allows."""

import pathlib
import re

import pytest
from fmpy import read_model_description

ROOT = pathlib.Path(__file__).resolve().parents[2]
# Every controller `make` ships, as the Makefile lists them (a test holds that list to `synth --list`).
CONTROLLERS = re.search(r"^CONTROLLERS := (.*)$", (ROOT / "Makefile").read_text(), re.M).group(1).split()


def describe(name):
    path = ROOT / "dist" / f"{name}.fmu"
    if not path.exists():
        pytest.fail(f"{path} not found: run `make` first")
    return read_model_description(str(path))


def edges(md, prefix, unknowns):
    """(unknown -> known) edges of one FMU, names prefixed by the FMU."""
    out = []
    for u in unknowns:
        assert u.dependencies is not None, f"{prefix}{u.variable.name} declares no dependencies"
        assert len(u.dependencies) == len(u.dependenciesKind)
        for d in u.dependencies:
            out.append((prefix + u.variable.name, prefix + d.name))
    return out


def has_cycle(graph):
    state = {}

    def visit(n):
        state[n] = 1
        for m in graph.get(n, ()):
            if state.get(m) == 1 or (m not in state and visit(m)):
                return True
        state[n] = 2
        return False

    return any(n not in state and visit(n) for n in list(graph))


@pytest.mark.parametrize("controller", CONTROLLERS)
def test_plant_and_controller_have_no_algebraic_loop(controller):
    plant, ctrl = describe("plant"), describe(controller)
    plant_names = {v.name for v in plant.modelVariables}
    for which in ["outputs", "initialUnknowns"]:
        graph = {}
        for a, b in edges(plant, "plant.", getattr(plant, which)) + edges(
            ctrl, "ctrl.", getattr(ctrl, which)
        ):
            graph.setdefault(a, set()).add(b)
        # Connections: a plant input reads the controller output of its name, a controller
        # input reads the plant output of its name.
        for v in ctrl.modelVariables:
            if v.causality == "output" and v.name in plant_names:
                graph.setdefault("plant." + v.name, set()).add("ctrl." + v.name)
            if v.causality == "input":
                assert v.name in plant_names, v.name
                graph.setdefault("ctrl." + v.name, set()).add("plant." + v.name)
        assert not has_cycle(graph), f"{controller}: algebraic loop through the {which}"


@pytest.mark.parametrize("name", ["plant", "road"] + CONTROLLERS)
def test_dependencies_name_only_allowed_knowns(name):
    md = describe(name)
    for u in md.outputs:
        for d, kind in zip(u.dependencies, u.dependenciesKind):
            assert d.causality == "input", (u.variable.name, d.name)
            assert kind in ("dependent", "constant", "fixed", "tunable", "discrete")
    for u in md.initialUnknowns:
        for d, kind in zip(u.dependencies, u.dependenciesKind):
            exact = d.causality == "parameter" and d.initial in (None, "exact")
            assert d.causality == "input" or exact, (u.variable.name, d.name)
            assert kind in ("dependent", "constant"), (u.variable.name, kind)
    assert md.defaultExperiment.tolerance is not None
