"""The index of the tests: each module of ``src/sarmotion`` and the test files that test it.

:data:`INDEX` maps every module (dotted, below ``sarmotion``; package ``__init__`` files
hold re-exports only and are not listed) to the files whose subject it is. A module
imported by many files only to build fixtures (``simulation.forward``, ``core.geometry``)
lists the files that test it, not every file that uses it. A private helper (``_x.py``)
is listed with the files that test it through the public module that uses it.

The index is checked against the code, from the source (:mod:`ast`, nothing imported):

- every module is listed, and every key is a module;
- every listed file exists, and every test file is listed (under a module, or in
  :data:`WHOLE_PACKAGE` when its subject is the package as a whole);
- the tests are laid out as the package: a test file of ``tests/<subpackage>/`` is
  listed under a module of ``sarmotion.<subpackage>``, a file of ``tests/`` itself under a
  top-level module (``sources``, ``errors``, ...) or in :data:`WHOLE_PACKAGE`, so a
  module's tests are found by its path; file names are unique across the folders (the
  index and ``conftest.py``'s slow lists name files by their names);
- every listed file reaches its module: the file imports the module, or a module whose
  own imports (transitively, package ``__init__`` files included) lead to it. A file that
  runs the command line (it imports ``cli.main`` or runs ``python -m sarmotion``) also
  reaches the module of each command it names (``"analyze"``, ``"track"``, ...,
  ``cli.main.COMMANDS``), which the command group imports only when the command runs.
"""

from __future__ import annotations

import ast
from collections import defaultdict
from functools import cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "sarmotion"
TESTS = ROOT / "tests"

#: Test files whose subject is the package as a whole, not one module.
WHOLE_PACKAGE = (
    "test_index.py",  # this index
    "test_layering.py",  # the imports between the layers
    "test_readme.py",  # the README's commands, as a user runs them
    "test_docs.py",  # the documentation site: tutorials, API reference, build
    "test_tiers.py",  # the fast and slow test tiers
    "test_signatures.py",  # the parameters of every function
)

#: Each module and the test files that test it.
INDEX: dict[str, tuple[str, ...]] = {
    "__main__": ("test_cli_hardening.py", "test_input_limits.py"),
    "_cluster": ("test_scheduler_security.py", "test_fuzz_options.py"),
    "_lazy": ("test_sources.py",),
    "_limits": ("test_input_limits.py", "test_io_blocks.py"),
    "_validation": ("test_imaging.py", "test_analysis.py"),
    "_version": ("test_io_native.py", "test_io_cphd.py"),
    "errors": ("test_errors.py",),
    # cli
    "cli.analyze": (
        "test_cli.py",
        "test_cli_demo.py",
        "test_analysis.py",
        "test_io_sicd.py",
        "test_analyze_device.py",
    ),  # fmt: skip
    "cli.autofocus": ("test_cli_autofocus.py",),
    "cli.collection": ("test_collection_run.py", "test_collection_cphd.py"),
    "cli.common": (
        "test_cli_hardening.py",
        "test_outputs.py",
        "test_cli_surfaces.py",
        "test_fuzz_options.py",
        "test_progress.py",
    ),
    "cli.describe": ("test_results_known.py",),
    "cli.convert": ("test_cli_cphd.py", "test_cli_autofocus.py", "test_outputs.py"),
    "cli.image": ("test_cli.py", "test_cli_autofocus.py", "test_cuda_sim.py", "test_io_sicd.py"),
    "cli.inject": ("test_cli.py", "test_cli_help.py"),
    "cli.inputs": ("test_cli_cphd.py", "test_cli.py", "test_cli_help.py", "test_cli_small.py"),
    "cli.main": ("test_cli.py", "test_cli_hardening.py", "test_errors.py"),
    "cli.paper": ("test_cli.py",),
    "cli.separate": ("test_cli.py",),
    "cli.simulate": ("test_cli.py", "test_outputs.py"),
    "cli.track": ("test_track.py", "test_cli_help.py"),
    # collection
    "collection.analysis": ("test_collection_analysis.py", "test_api.py"),
    "collection.extract": ("test_collection.py",),
    "collection.merge": (
        "test_collection.py",
        "test_collection_sidelobes.py",
        "test_collection_doppler.py",
        "test_collection_smear.py",
    ),
    "collection.plan": (
        "test_collection.py",
        "test_collection_run.py",
        "test_collection_region.py",
    ),
    "collection.resample": ("test_collection_resample.py",),
    "collection.run": (
        "test_collection_run.py",
        "test_collection_cphd.py",
        "test_collection_dead_zone.py",
        "test_collection_doppler.py",
    ),
    # core
    "core.acquisition": ("test_acquisition.py",),
    "core.ascent": ("test_ascent.py",),
    "core.blocks": ("test_collection.py", "test_collection_run.py"),
    "core.constants": ("test_geometry.py", "test_signals.py"),
    "core.geometry": ("test_geometry.py", "test_acquisition.py"),
    "core.polygon": ("test_collection_region.py",),
    "core.progress": ("test_imaging.py", "test_fast_imaging.py"),
    "core.radar": ("test_signals.py", "test_simulate.py"),
    "core.spectral": ("test_spectral_fast.py", "test_simulate.py"),
    "core.text": ("test_api.py", "test_cli_small.py"),
    "core.traces": ("test_acquisition.py", "test_io_native.py"),
    # documents
    "documents.peaks": ("test_cli.py",),
    "documents.results": (
        "test_analysis.py",
        "test_report_html.py",
        "test_results_known.py",
        "test_documents_schema.py",
    ),
    "documents.schema": ("test_documents_schema.py", "test_results_known.py"),
    "documents.roads": ("test_track.py", "test_input_limits.py"),
    "documents.separation": ("test_cli.py",),
    "documents.tracks": ("test_track.py",),
    # imaging
    "imaging._block_pool": ("test_block_pool.py", "test_cuda_host.py", "test_fast_imaging.py"),
    "imaging._bp_common": ("test_imaging.py", "test_fast_imaging.py"),
    "imaging._bp_kernels": ("test_fast_imaging.py", "test_imaging.py"),
    "imaging._bp_reference": ("test_imaging.py", "test_backprojection_accuracy.py"),
    "imaging._bp_table": ("test_fast_imaging.py", "test_imaging_threads.py"),
    "imaging._cuda_kernels": ("test_cuda_sim.py",),
    "imaging._cuda_ffbp_kernels": ("test_cuda_sim.py",),
    "imaging._cuda_host": ("test_cuda_host.py", "test_cuda_sim.py"),
    "imaging._cuda_table": ("test_cuda_sim.py",),
    "imaging._ffbp_kernels": (
        "test_fast_imaging.py",
        "test_ffbp_oblique.py",
        "test_ffbp_accuracy.py",
        "test_ffbp_plan.py",
    ),  # fmt: skip
    "imaging._pack_simd": ("test_fast_imaging.py",),
    "imaging._simd": ("test_fast_imaging.py",),
    "imaging.autofocus": ("test_autofocus.py",),
    "imaging.backprojection": (
        "test_imaging.py",
        "test_backprojection_accuracy.py",
        "test_fast_imaging.py",
        "test_imaging_threads.py",
    ),
    "imaging.cuda": ("test_cuda_sim.py",),
    "imaging.cuda_ffbp": ("test_cuda_sim.py",),
    "imaging.exact_sum": ("test_backprojection_accuracy.py",),
    "imaging.ffbp": (
        "test_fast_imaging.py",
        "test_ffbp_oblique.py",
        "test_ffbp_accuracy.py",
        "test_ffbp_plan.py",
    ),
    "imaging.grid": ("test_imaging.py",),
    "imaging.peaks": ("test_imaging.py", "test_analysis.py"),
    "imaging.point_response": ("test_point_response.py",),
    "imaging.quality": ("test_quality.py",),
    "imaging.resolution": ("test_imaging.py", "test_acquisition.py"),
    "imaging.sidelobes": ("test_stationary_listing.py", "test_collection_sidelobes.py"),
    # io
    "io.cphd": (
        "test_io_cphd.py",
        "test_fuzz_cphd.py",
        "test_io_blocks.py",
        "test_collection_cphd.py",
    ),
    "io.errors": ("test_errors.py", "test_input_limits.py"),
    "io.files": ("test_sources.py",),
    "io.gotcha": ("test_io_gotcha.py", "test_fuzz_gotcha.py", "test_inject_gotcha.py"),
    "io.jsonfile": ("test_analysis.py", "test_track.py"),
    "io.matv5": ("test_io_gotcha.py", "test_errors.py"),
    "io.native": ("test_io_native.py", "test_fuzz_native.py", "test_io_blocks.py"),
    "io.plausibility": ("test_input_limits.py", "test_io_gotcha.py", "test_io_native.py"),
    "io.sicd": ("test_io_sicd.py",),
    "io.staging": ("test_outputs.py", "test_cli_hardening.py"),
    # motion
    "motion._aligned": ("test_aligned_fast.py",),
    "motion.acceleration": ("test_acceleration.py",),
    "motion.aperture": ("test_tracking.py", "test_fast_movers.py"),
    "motion.bounds": ("test_movers_detection.py", "test_acceleration.py"),
    "motion.coherent": ("test_coherent_detection.py",),
    "motion.defocus": ("test_defocus.py",),
    "motion.cross_range": ("test_velocity.py",),
    "motion.detector": ("test_movers_detection.py", "test_detector_null.py"),
    "motion.likelihood": ("test_likelihood_fit.py", "test_movers_detection.py"),
    "motion.location": ("test_velocity.py",),
    "motion.phase_space": ("test_phase_space.py",),
    "motion.range_speed": ("test_velocity.py", "test_aligned_fast.py"),
    "motion.speed_resolution": ("test_velocity.py", "test_fast_movers.py"),
    "motion.velocity": ("test_velocity.py", "test_tracking.py"),
    "motion.wigner": ("test_phase_space.py",),
    # paper
    "paper.figures._context": ("test_paper.py",),
    "paper.figures.build": ("test_paper.py",),
    "paper.figures.captions": ("test_paper.py",),
    "paper.figures.fig_imaging": ("test_paper.py",),
    "paper.figures.fig_motion": ("test_paper.py",),
    "paper.figures.fig_rank": ("test_paper.py",),
    "paper.figures.fig_separation": ("test_paper.py",),
    "paper.figures.fig_setup": ("test_paper.py",),
    "paper.rank.model": ("test_rank.py",),
    "paper.rank.numerical": ("test_rank.py",),
    "paper.rank.prediction": ("test_rank.py",),
    "paper.rank.symbols": ("test_rank.py",),
    # pipeline
    "pipeline._timing": ("test_analysis.py",),
    "pipeline.analyze": ("test_analysis.py", "test_analyze_device.py"),
    "pipeline.detection": ("test_movers_detection.py", "test_detector_null.py"),
    "pipeline.movers": ("test_movers_detection.py", "test_fast_movers.py", "test_fit_lobes.py"),
    "pipeline.options": ("test_analysis.py", "test_analyze_device.py"),
    "pipeline.refit": ("test_refit.py",),
    "pipeline.defocused": ("test_defocus.py",),
    "pipeline.family": ("test_results_known.py",),
    "pipeline.results": ("test_analysis.py", "test_errors.py", "test_api.py"),
    "pipeline.stages": ("test_analysis.py", "test_errors.py"),
    "pipeline.truth": ("test_analysis.py", "test_truth_matching.py"),
    # report
    "report.analysis": ("test_api.py",),
    "report.analysis_figures": ("test_results_known.py", "test_report_style.py"),
    "report.autofocus": ("test_cli_autofocus.py",),
    "report.collection": ("test_collection_run.py", "test_report_style.py"),
    "report.html": ("test_report_html.py",),
    "report.page": ("test_report_style.py",),
    "report.plotting": ("test_report_html.py", "test_cli.py", "test_report_style.py"),
    "report.tracks": ("test_track.py", "test_results_known.py", "test_report_style.py"),
    # separation
    "separation._ialm": ("test_rpca.py", "test_rpca_stacked.py"),
    "separation._stacked_ialm": ("test_rpca_stacked.py",),
    "separation._thresholding": ("test_rpca.py",),
    "separation._windows": ("test_rpca.py", "test_rpca_stacked.py"),
    "separation.accaltproj": ("test_rpca.py",),
    "separation.annihilation": ("test_separation.py", "test_transforms.py"),
    "separation.candidates": ("test_separation.py", "test_separation_noise.py"),
    "separation.combined": ("test_separation.py", "test_separation_noise.py"),
    "separation.dispatch": ("test_separation.py", "test_analysis.py"),
    "separation.quality": ("test_separation.py", "test_separation_gotcha.py"),
    "separation.result": ("test_separation.py",),
    "separation.rpca": ("test_rpca.py", "test_rpca_stacked.py"),
    "separation.rpca_separation": ("test_separation.py", "test_separation_gotcha.py"),
    "separation.transforms": ("test_transforms.py",),
    # simulation
    "simulation.collection": ("test_collection_cphd.py",),
    "simulation.echoes": ("test_echoes.py",),
    "simulation.forward": ("test_simulate.py", "test_signals.py"),
    "simulation.paths": ("test_paths.py", "test_acceleration.py", "test_turns.py"),
    "simulation.scene": ("test_scene.py", "test_fuzz_scene.py"),
    "sources": ("test_sources.py",),
    "simulation.signals": ("test_signals.py",),
    # tracking
    "tracking.ends": ("test_ends.py", "test_track.py"),
    "tracking.roads": ("test_track.py", "test_road_misses.py"),
    "tracking.scale": ("test_track.py", "test_scheduler_security.py"),
    "tracking.sub_apertures": ("test_track.py",),
    "tracking.track": ("test_track.py",),
    "tracking.wide_aspect": ("test_wide_aspect.py",),
    "tracking.tracker": ("test_track.py", "test_turns.py"),
    "tracking.turns": ("test_turns.py",),
    "tracking.turn_rate": ("test_turn_rate.py",),
    "tracking.coherent": ("test_coherent.py",),
}


# ------------------------------------------------------------------ the import graph
def _path(module: str) -> Path | None:
    """The file of ``module`` (``""`` is the package; a package is its ``__init__.py``)."""
    base = SRC.joinpath(*module.split(".")) if module else SRC
    if (base / "__init__.py").is_file():
        return base / "__init__.py"
    file = base.with_suffix(".py")
    return file if file.is_file() else None


def _modules() -> list[str]:
    """Every module of the package but the package ``__init__`` files, dotted."""
    parts = (p.relative_to(SRC).with_suffix("").parts for p in sorted(SRC.rglob("*.py")))
    return [".".join(p) for p in parts if p[-1] != "__init__"]


def _absolute(current: str, level: int, module: str | None) -> str | None:
    """The module that ``from <level dots><module> import ...`` in ``current`` names."""
    parts = current.split(".") if current else []
    if _path(current) is None or _path(current).name != "__init__.py":
        parts = parts[:-1]
    parts = parts[: len(parts) - (level - 1)] + (module.split(".") if module else [])
    name = ".".join(parts)
    return name if _path(name) is not None else None


@cache
def _exported(package: str) -> dict[str, str]:
    """Names a package's ``__init__`` imports from its modules, and the module of each."""
    path = _path(package)
    if path is None or path.name != "__init__.py":
        return {}
    out = {}
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.level:
            source = _absolute(package, node.level, node.module)
            if source is not None:
                for alias in node.names:
                    out[alias.asname or alias.name] = _resolve(source, alias.name)
    return out


def _resolve(package: str, name: str) -> str:
    """The module ``from <package> import <name>`` reaches: a submodule or the definer."""
    sub = f"{package}.{name}" if package else name
    if _path(sub) is not None:
        return sub
    return _exported(package).get(name, package)


def _imports(tree: ast.AST, current: str | None = None) -> set[str]:
    """Modules of the package that a file imports (relative imports need ``current``)."""
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found |= {
                a.name.removeprefix("sarmotion").removeprefix(".")
                for a in node.names
                if a.name.split(".")[0] == "sarmotion"
            }
        elif isinstance(node, ast.ImportFrom):
            if node.level == 0 and (node.module or "").split(".")[0] == "sarmotion":
                package = node.module.removeprefix("sarmotion").removeprefix(".")
            elif node.level and current is not None:
                package = _absolute(current, node.level, node.module)
            else:
                continue
            if package is not None:
                found |= {_resolve(package, a.name) for a in node.names}
    return found


def _parents(module: str) -> set[str]:
    """The packages whose ``__init__`` runs when ``module`` is imported (not the top)."""
    parts = module.split(".")
    return {".".join(parts[:k]) for k in range(1, len(parts))}


@cache
def _graph() -> dict[str, set[str]]:
    """Each module (and package) of the package and the modules it imports."""
    graph: dict[str, set[str]] = defaultdict(set)
    packages = {".".join(p.relative_to(SRC).parent.parts) for p in SRC.rglob("__init__.py")}
    for module in [*_modules(), *packages]:
        tree = ast.parse(_path(module).read_text())
        graph[module] = {m for m in _imports(tree, module) if m} | _parents(module)
    return graph


def _commands() -> dict[str, str]:
    """``cli.main.COMMANDS``: each command's name and its module, read from the source."""
    tree = ast.parse((SRC / "cli" / "main.py").read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.AnnAssign) and ast.unparse(node.target) == "COMMANDS":
            return {k: f"cli.{v[0]}" for k, v in ast.literal_eval(node.value).items()}
    raise AssertionError("cli/main.py defines no COMMANDS")


def _strings(tree: ast.AST) -> set[str]:
    return {
        n.value for n in ast.walk(tree) if isinstance(n, ast.Constant) and isinstance(n.value, str)
    }


def _runs_module(tree: ast.AST) -> bool:
    """``[..., "-m", "sarmotion", ...]``: the file runs ``python -m sarmotion``."""
    for node in ast.walk(tree):
        if isinstance(node, ast.List):
            items = [e.value if isinstance(e, ast.Constant) else None for e in node.elts]
            if any(a == "-m" and b == "sarmotion" for a, b in zip(items, items[1:], strict=False)):
                return True
    return False


@cache
def _reached(test_file: str) -> frozenset[str]:
    """Every module a test file reaches (module docstring)."""
    tree = ast.parse(_test_files()[test_file].read_text())
    start = {m for m in _imports(tree) for m in (m, *_parents(m)) if m}
    if _runs_module(tree):
        start.add("__main__")
    graph = _graph()
    seen: set[str] = set()
    todo = list(start)
    while todo:
        module = todo.pop()
        if module in seen:
            continue
        seen.add(module)
        todo.extend(graph.get(module, ()))
    if "cli.main" in seen:  # the commands it names, imported when they run
        names = _strings(tree)
        todo = [m for name, m in _commands().items() if name in names]
        while todo:
            module = todo.pop()
            if module not in seen:
                seen.add(module)
                todo.extend(graph.get(module, ()))
    return frozenset(seen)


def _test_files() -> dict[str, Path]:
    """Every test file by its name: ``tests/test_*.py`` and ``tests/<subpackage>/test_*.py``."""
    return {p.name: p for p in sorted(TESTS.rglob("test_*.py"))}


# ------------------------------------------------------------------------- the tests
def test_every_module_is_indexed():
    modules = set(_modules())
    assert sorted(modules - set(INDEX)) == [], "modules without tests in the index"
    assert sorted(set(INDEX) - modules) == [], "index keys that are not modules"


def test_every_listed_file_exists_and_every_test_file_is_listed():
    listed = {f for files in INDEX.values() for f in files} | set(WHOLE_PACKAGE)
    files = _test_files()
    assert sorted(f for f in listed if f not in files) == []
    assert sorted(set(files) - listed) == []
    assert all(files for files in INDEX.values())


def test_test_file_names_are_unique():
    names = [p.name for p in TESTS.rglob("test_*.py")]
    assert sorted({n for n in names if names.count(n) > 1}) == []


def test_tests_are_laid_out_as_the_package():
    subjects: dict[str, set[str]] = defaultdict(set)
    for module, files in INDEX.items():
        for name in files:
            subjects[name].add(module.split(".")[0] if "." in module else "")
    misplaced = []
    for name, path in _test_files().items():
        folder = path.parent.relative_to(TESTS).as_posix()
        folder = "" if folder == "." else folder
        if folder == "" and name in WHOLE_PACKAGE:
            continue
        if folder not in subjects[name] or (folder and not (SRC / folder).is_dir()):
            misplaced.append(f"{path.relative_to(TESTS)}: subjects {sorted(subjects[name])}")
    assert misplaced == []


@pytest.mark.parametrize("module", sorted(INDEX))
def test_every_listed_file_reaches_its_module(module):
    assert [f for f in INDEX[module] if module not in _reached(f)] == []


def test_the_reach_is_not_everything():
    """A check that cannot fail is no check: imports decide, and only they."""
    assert "imaging.ffbp" not in _reached("test_rank.py")
    assert "cli.track" not in _reached("test_cli_demo.py")  # it runs ``demo`` only
    assert "cli.track" in _reached("test_track.py")
    assert "imaging._ffbp_kernels" in _reached("test_ffbp_oblique.py")  # through ffbp
    assert _resolve("imaging", "backproject") == "imaging.backprojection"
    assert _resolve("imaging", "ffbp") == "imaging.ffbp"
