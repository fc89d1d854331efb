"""The layout rules of docs/architecture.md: what each package may import, the method
families' rooms under stages, no import cycle, module size."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "coopproc"
SHARED = (
    "model",
    "names",
    "memory",
    "sampling",
    "sensors",
    "errors",
    "frames",
    "timeconv",
    "configtools",
)

#: package -> coopproc packages/modules it must not import
FORBIDDEN: dict[str, tuple[str, ...]] = {
    # the model layer: numpy/numba/scipy and the shared modules only (issue 34)
    "estimation": ("stages", "run", "report", "cli", "sim", "checks", "io", "ins", "gnss"),
    "io": ("stages", "run", "report", "cli", "sim", "checks"),
    "checks": ("stages", "run", "report", "cli", "sim"),
    "stages": ("io", "run", "report", "cli", "sim", "checks"),
    # reporters read results (estimation.locate_result), not algorithms
    "report": ("io", "run", "cli", "sim", "checks", "stages"),
    "sim": ("stages", "run", "report", "checks", "cli"),
    "ins": ("io", "run", "report", "cli", "sim", "checks", "stages"),
    "gnss": ("stages", "run", "report", "cli", "sim", "checks", "ins"),
    "run": ("cli",),
}

#: "under ~400 lines" (ARCHITECTURE, issue 18)
MAX_LINES = 420


def _modules() -> list[Path]:
    return sorted(ROOT.rglob("*.py"))


def _imports(path: Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
        elif isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
    return {n.removeprefix("coopproc.") for n in names if n.startswith("coopproc.")}


def _package(path: Path) -> str:
    rel = path.relative_to(ROOT)
    return rel.parts[0] if len(rel.parts) > 1 else rel.stem


@pytest.mark.parametrize("path", _modules(), ids=lambda p: str(p.relative_to(ROOT)))
def test_imports_follow_the_layers(path: Path) -> None:
    package = _package(path)
    imported = _imports(path)
    if package in SHARED:
        others = {i for i in imported if i.split(".")[0] not in SHARED}
        assert not others, f"shared module {path.name} imports {sorted(others)}"
    for banned in FORBIDDEN.get(package, ()):
        bad = sorted(i for i in imported if i == banned or i.startswith(banned + "."))
        assert not bad, f"{path.relative_to(ROOT)} ({package}) must not import {bad}"


def test_modules_are_small() -> None:
    sizes = {p: len(p.read_text(encoding="utf-8").splitlines()) for p in _modules()}
    big = {str(p.relative_to(ROOT)): n for p, n in sizes.items() if n > MAX_LINES}
    assert not big, f"modules over {MAX_LINES} lines: {big}"


def test_cli_holds_no_algorithms() -> None:
    """The CLI calls the library: no numpy in a command module."""
    for path in (ROOT / "cli").glob("*.py"):
        assert "numpy" not in {i.split(".")[0] for i in _raw_imports(path)}, path.name


def _raw_imports(path: Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module)
        elif isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
    return names


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def import_graph() -> dict[str, set[str]]:
    """coopproc's modules -> the coopproc modules each imports, at module level or inside a
    function (``TYPE_CHECKING`` blocks included); ``from coopproc.x import y`` with ``y`` a
    module imports ``coopproc.x.y``, else ``coopproc.x``."""
    paths = {_module_name(p): p for p in _modules()}
    graph: dict[str, set[str]] = {}
    for name, path in paths.items():
        edges: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                for alias in node.names:
                    sub = f"{node.module}.{alias.name}"
                    edges.add(sub if sub in paths else node.module)
            elif isinstance(node, ast.Import):
                edges.update(alias.name for alias in node.names)
        graph[name] = {e for e in edges if e in paths and e != name}
    return graph


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import cycle ``[a, b, ..., a]`` of ``graph``, None when it has none (iterative
    depth-first search: a back edge to a module on the current path closes a cycle)."""
    state: dict[str, int] = {}  # 1 on the path, 2 done
    for root in sorted(graph):
        if root in state:
            continue
        path = [root]
        stack = [iter(sorted(graph[root]))]
        state[root] = 1
        while stack:
            nxt = next(stack[-1], None)
            if nxt is None:
                state[path.pop()] = 2
                stack.pop()
            elif state.get(nxt) == 1:
                return [*path[path.index(nxt) :], nxt]
            elif nxt not in state:
                state[nxt] = 1
                path.append(nxt)
                stack.append(iter(sorted(graph[nxt])))
    return None


def test_no_import_cycle() -> None:
    cycle = find_cycle(import_graph())
    assert cycle is None, "import cycle: " + " -> ".join(cycle or [])


def test_the_cycle_finder_finds_cycles() -> None:
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a", "d"}, "d": set()}
    assert find_cycle(graph) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": set(), "d": {"c"}}) is None
    # the graph counts function-level imports and a module imported by its package
    graph = import_graph()
    assert "coopproc.estimation.robust" in graph["coopproc.stages.fusion.ekf"]
    assert "coopproc.run.outages" in graph["coopproc.run.pipeline"]


def test_the_model_layer_is_below_the_stages() -> None:
    """estimation is imported by the INS engine and the stages, and imports neither."""
    graph = import_graph()
    users = {
        m for m, edges in graph.items() if any(e.startswith("coopproc.estimation") for e in edges)
    }
    assert {
        "coopproc.ins.kernels",
        "coopproc.ins.smoother",
        "coopproc.report.locate_figures",
    } <= users
    below = {e for m, edges in graph.items() if m.startswith("coopproc.estimation.") for e in edges}
    assert all(e.split(".")[1] in (*SHARED, "estimation") for e in below), sorted(below)


#: the method families' rooms under coopproc/stages (docs/architecture.md, issue 34 part 2)
ROOMS = ("ranging", "fusion", "anchors", "ins", "gnss", "odometry", "particle")
#: below the rooms, inside stages: what more than one room takes; imports no room
STAGES_BELOW = ("base", "shared")
#: the only arrows from one room into another: a family that starts from another's method
ROOM_STARTS = {
    # an INS without simultaneous ranges aligns on the UWB-only range_rts track
    ("ins", "anchors"): {"coopproc.stages.anchors.range_kf"},
    # paper 002's INS error states in the tight filter start as the INS methods do
    ("gnss", "ins"): {"coopproc.stages.ins.ins_setup", "coopproc.stages.ins.ins_stage"},
}
#: registry stage name (its method-name prefix) -> the room its entry lives in
STAGE_ROOMS = {
    "fusion": "fusion",
    "lsq": "anchors",
    "range": "anchors",
    "ins": "ins",
    "gnss": "gnss",
    "tight": "gnss",
    "odo": "odometry",
    "ranging": "ranging",
    "median": "ranging",
}


def _stages_part(module: str) -> str | None:
    """The room or below-rooms module (``fusion``, ``shared``, ``base``, ...) of a
    ``coopproc.stages.*`` module, None outside the stages."""
    parts = module.split(".")
    return parts[2] if len(parts) > 2 and parts[:2] == ["coopproc", "stages"] else None


def room_violations(graph: dict[str, set[str]]) -> list[str]:
    """The imports that break the rooms' rule: a room imports from no other room (but the
    starts of :data:`ROOM_STARTS`), the modules below the rooms import no room; only
    ``stages.registry`` (the entries) and the runner above may import any room."""
    bad = []
    for module, edges in sorted(graph.items()):
        mine = _stages_part(module)
        if mine is None or mine == "registry":
            continue
        for edge in sorted(edges):
            theirs = _stages_part(edge)
            if theirs is None or theirs == mine or theirs in STAGES_BELOW:
                continue
            if edge in ROOM_STARTS.get((mine, theirs), set()):
                continue
            bad.append(f"{module} -> {edge}")
    return bad


def test_each_room_holds_its_family_only() -> None:
    graph = import_graph()
    bad = room_violations(graph)
    assert not bad, "imports across the method families' rooms: " + "; ".join(bad)
    # the rule can fail: an odometer module taking the fusion's EKF, the shared LS
    # taking an anchors module, and an undeclared start are caught
    probe = {
        "coopproc.stages.odometry.odo_uwb": {"coopproc.stages.fusion.ekf"},
        "coopproc.stages.shared.lsq": {"coopproc.stages.anchors.uwb_kf"},
        "coopproc.stages.gnss.tight_ins": {"coopproc.stages.anchors.range_kf"},
        "coopproc.stages.ins.ins_setup": {"coopproc.stages.anchors.range_kf"},
        "coopproc.stages.registry": {"coopproc.stages.fusion.entry"},
    }
    assert room_violations(probe) == [
        "coopproc.stages.gnss.tight_ins -> coopproc.stages.anchors.range_kf",
        "coopproc.stages.odometry.odo_uwb -> coopproc.stages.fusion.ekf",
        "coopproc.stages.shared.lsq -> coopproc.stages.anchors.uwb_kf",
    ]


def test_the_stages_are_the_declared_rooms() -> None:
    """Every package under stages is a declared room (or ``shared``), every room exists."""
    packages = {p.parent.name for p in (ROOT / "stages").glob("*/__init__.py")}
    assert packages == {*ROOMS, "shared"}
    modules = {p.stem for p in (ROOT / "stages").glob("*.py")} - {"__init__"}
    assert modules == {"base", "registry"}


def test_each_registry_entry_lives_in_its_family_room() -> None:
    from coopproc.stages.registry import POSITION_STAGES, RANGE_STAGES

    stages = {**RANGE_STAGES, **POSITION_STAGES}
    assert len(stages) >= 18  # fusion, 5 anchors, 2 odometry, 4 INS, 4 GNSS; ranging, median
    for name, stage in stages.items():
        room = STAGE_ROOMS[name.split("_")[0]]
        assert _stages_part(stage.run.__module__) == room, (name, stage.run.__module__)


#: the range model (coopproc/estimation/range_model.py) written again: a floored sum of
#: squares under a root, a root of component squares, the length of a difference
RANGE_FORMULAS = (
    re.compile(r"sqrt\(\s*(?:np\.)?max(?:imum)?\(\s*sq\b"),
    re.compile(r"sqrt\((\w+(?:\[[^]]*\])?) \* \1 \+ (\w+(?:\[[^]]*\])?) \* \2"),
    re.compile(r"(?:hypot|linalg\.norm)\((?=[^#]*\w\s-\s)"),
)
#: where such a formula measures something else than a predicted range: (module, code)
NOT_RANGES = {
    ("stages/fusion/ekf.py", "travel = np.sqrt(ue * ue + un * un)"),  # a step's length
    ("stages/particle/aco.py", "np.sqrt(max(ex * ex + ey * ey, min2))"),  # particle spacing
    ("stages/anchors/anchor_lsq.py", "np.linalg.norm(np.nan_to_num(xm - x)"),  # two fixes
    ("stages/anchors/anchor_lsq.py", "np.linalg.norm(xm - ref, axis=1)"),  # fix to reference
    ("stages/anchors/anchor_lsq.py", "np.linalg.norm(x - anchors[:, :dim].mean"),  # to centroid
    ("stages/gnss/tight_ins.py", "np.linalg.norm(pts - pts[0]"),  # spread of start points
    ("stages/particle/locate.py", "np.hypot(tr.east_m - ref_en"),  # error against reference
    ("checks/framecheck.py", "np.linalg.norm(moved[:, :2] - obs.p[:, :2]"),  # the correction
    ("run/stochastic.py", "np.linalg.norm(mean - centre"),  # gyro rates
    ("run/stochastic.py", "np.linalg.norm(b - a, axis=1)"),  # a displacement
    ("run/positions_table.py", "np.hypot(enu[:, 0] - truth[:, 0]"),  # error against truth
}
#: the packages whose estimators predict ranges (the simulator and GNSS pseudoranges aside)
RANGE_USERS = ("stages", "ins", "checks", "run")


def test_the_range_model_has_one_definition() -> None:
    """Every predicted UWB range is estimation.range_model's (issue 34 part 1)."""
    found = []
    for path in _modules():
        rel = path.relative_to(ROOT).as_posix()
        if rel.split("/")[0] not in RANGE_USERS:
            continue
        for no, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            code = line.split("#")[0]
            if any(p.search(code) for p in RANGE_FORMULAS) and not any(
                m == rel and frag in code for m, frag in NOT_RANGES
            ):
                found.append(f"{rel}:{no}: {code.strip()}")
    assert not found, "range formulas outside estimation/range_model.py:\n" + "\n".join(found)


def test_the_range_formula_finder_finds_them() -> None:
    for code in (
        "rho = np.sqrt(max(sq, 1e-12))",
        "d = np.sqrt(dx * dx + dy * dy) - z[j]",
        "dist = np.linalg.norm(pos1_m - pos2_m, axis=1)",
        "d_hat = np.hypot(cloud.east - ax, cloud.north - ay)",
    ):
        assert any(p.search(code) for p in RANGE_FORMULAS), code
    assert not any(
        p.search("step = np.linalg.norm(np.diff(p, axis=0), axis=1)") for p in RANGE_FORMULAS
    )


#: where the process's memory is given back (memory.py, issue 34 part 5): at the runner's
#: phase boundaries (cli/run.py, run/batch.py) and once before the figures' workers fork
#: (run/output.py); everywhere else a scope marked @gives_back; nothing calls the
#: allocator or takes a callback to let go of the session
MEMORY_CALLS = {
    "release_freed_memory": {"cli/run.py", "run/batch.py", "run/output.py"},
    "malloc_trim": set(),
    "mallopt": set(),
    "samples_spent": set(),
}
#: the scopes whose working memory goes back when they return
MEMORY_SCOPES = {
    "stages/fusion/fuse.py": 2,  # the forward pass; the passes before the trajectories
    "stages/ranging/stage.py": 2,  # the DI passes; each pair's rows
    "run/positions_table.py": 1,  # each platform's samples once its rows are in
    "report/page_workers.py": 1,  # each figure page in its worker
}


def test_the_memory_lifetime_is_managed_in_one_place() -> None:
    found: dict[str, set[str]] = {name: set() for name in MEMORY_CALLS}
    scopes: dict[str, int] = {}
    for path in _modules():
        rel = path.relative_to(ROOT).as_posix()
        if rel == "memory.py":
            continue
        code = "\n".join(line.split("#")[0] for line in path.read_text("utf-8").splitlines())
        for name in MEMORY_CALLS:
            if name in code:
                found[name].add(rel)
        if code.count("@gives_back"):
            scopes[rel] = code.count("@gives_back")
    assert found == MEMORY_CALLS
    assert scopes == MEMORY_SCOPES
