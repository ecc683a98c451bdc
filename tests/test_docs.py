"""docs/plugins.md runs as written: its package files, entry points, code and config."""

import re
import runpy
import sys
from pathlib import Path

import numpy as np
import pytest
import tomllib

from graphseg.config import Config
from graphseg.graphs import edge_adders
from graphseg.testing.plugins import refresh_registries, write_dist_info

DOCS = Path(__file__).resolve().parents[1] / "docs"
FENCE = re.compile(r"```(\w+)\n(.*?)```", flags=re.S)


def blocks(doc, lang):
    return [body for kind, body in FENCE.findall((DOCS / doc).read_text()) if kind == lang]


@pytest.fixture
def extras_installed(tmp_path, monkeypatch):
    """The tutorial's package, installed as pip would: files plus a dist-info with its entry points."""
    site = tmp_path / "site"
    for body in blocks("plugins.md", "python"):
        first = body.splitlines()[0]
        if m := re.fullmatch(r"# (\S+\.py)", first):
            f = site / m.group(1)
            f.parent.mkdir(parents=True, exist_ok=True)
            f.write_text(body)
            (f.parent / "__init__.py").touch()
    (toml,) = blocks("plugins.md", "toml")
    meta = tomllib.loads(toml)
    write_dist_info(site, meta["project"]["name"], meta["project"]["entry-points"])
    monkeypatch.syspath_prepend(str(site))
    refresh_registries()
    yield site
    for name in ("mean_colour", "touching"):
        edge_adders.unregister(name)
    from graphseg.graphs.registry import operations

    operations.unregister("drop_thin")
    for mod in [m for m in sys.modules if m.startswith("graphseg_extras")]:
        del sys.modules[mod]
    monkeypatch.undo()
    refresh_registries()


def test_plugins_tutorial_runs_and_its_criteria_work(extras_installed, tmp_path, capsys):
    assert {"mean_colour", "touching"} <= set(edge_adders.names())  # found through the entry points
    ns: dict = {}
    for body in blocks("plugins.md", "python"):
        if not re.fullmatch(r"# (\S+\.py)", body.splitlines()[0]):
            exec(compile(body, str(DOCS / "plugins.md"), "exec"), ns)
    out = capsys.readouterr().out
    truth = len(ns["scene"].objects)
    assert truth == 2
    # the 2D criterion adds edges and repairs GraphSeg-minus's over-segmentation
    assert ns["minus"].num_objects > truth
    assert ns["colour"].info["stages"][0]["adders"]["mean_colour"]["edges"] > 0
    assert ns["colour"].num_objects == truth
    crit0 = ns["colour"].graphs[0].edge_attr["criterion"]
    assert (crit0 == "mean_colour").any()
    # the 3D criterion adds edges in the second stage and does the same
    assert ns["touch"].info["stages"][1]["adders"]["touching"]["edges"] > 0
    assert ns["touch"].num_objects == truth
    # the graph operation runs as a step of the list and is recorded in the objects graph
    assert ns["thin"].num_objects == truth and "drop_thin" in ns["thin"].objects_graph.meta["steps"]
    assert f"{truth} {ns['thin'].objects_graph.meta['steps']}" in out
    assert f"{ns['minus'].num_objects} -> 2" in out and "[['pixel_match']]" in out
    # the backend plugins and the contractor, by name through their entry points: the millimetre
    # lifter with label propagation gives exactly the built-in rgbd lifter's objects with union-find
    builtin, plugins = ns["builtin"], ns["plugins"]
    assert builtin.num_objects == plugins.num_objects == truth
    assert all(np.array_equal(a, b) for a, b in zip(builtin.labels, plugins.labels))
    assert plugins.config.contractor.name == "label_propagation"
    assert ns["mixed"].num_objects == 3 and f"{builtin.num_objects} {plugins.num_objects}" in out  # as the page says

    # the YAML config of the page, loaded and run
    (yaml_text,) = blocks("plugins.md", "yaml")
    (tmp_path / "extras.yaml").write_text(yaml_text)
    cfg = Config.load(tmp_path / "extras.yaml")
    assert cfg.stage_names() == [["pixel_match", "mean_colour"], ["touching"]]
    assert cfg.criterion_options("mean_colour") == {"max_distance": 30.0}
    r = ns["graphseg"].segment(ns["scene"], ns["masks"], ns["matches"], cfg)
    assert r.num_objects == truth and (r.graphs[0].edge_attr["criterion"] == "mean_colour").any()
    cfg.save(tmp_path / "saved.yaml")
    assert Config.load(tmp_path / "saved.yaml") == cfg

    # the error messages quoted on the page
    (tmp_path / "bad.yaml").write_text(yaml_text.replace("gap:", "gapp:"))
    with pytest.raises(Exception, match=re.escape("touching: unknown option 'gapp'; valid options: gap, min_pairs")):
        Config.load(tmp_path / "bad.yaml")
    (tmp_path / "bad2.yaml").write_text(yaml_text.replace("mean_colour", "mean_color"))
    with pytest.raises(Exception, match=re.escape("unknown edge criterion 'mean_color'; installed choices: pixel_match, chamfer_3d, dino")):
        Config.load(tmp_path / "bad2.yaml")


#: The entry-point group of each plugin kind and its registry.
KIND_REGISTRIES = {
    "graphseg.edge_adders": "graphseg.graphs.registry:edge_adders",
    "graphseg.segmenters": "graphseg.backends.registry:segmenters",
    "graphseg.matchers": "graphseg.backends.registry:matchers",
    "graphseg.lifters": "graphseg.backends.registry:lifters",
    "graphseg.contractors": "graphseg.graphs.registry:contractors",
    "graphseg.operations": "graphseg.graphs.registry:operations",
}


def _registry(target):
    import importlib

    module, attr = target.split(":")
    return getattr(importlib.import_module(module), attr)


def test_every_plugin_kind_is_one_module_its_test_and_an_entry_point(extras_installed):
    """Issue 24: a criterion, a segmenter, a matcher, a lifter and a contractor, each one module plus its test."""
    files = [m.group(1) for body in blocks("plugins.md", "python") if (m := re.fullmatch(r"# (\S+\.py)", body.splitlines()[0]))]
    modules = {f for f in files if f.startswith("graphseg_extras/")}
    tests = {f for f in files if f.startswith("tests/")}
    (toml,) = blocks("plugins.md", "toml")
    groups = tomllib.loads(toml)["project"]["entry-points"]
    assert set(groups) == set(KIND_REGISTRIES)  # every kind has an example
    for group, entries in groups.items():
        for name, target in entries.items():
            cls = _registry(KIND_REGISTRIES[group]).get(name)  # found through the installed entry point
            module, attr = target.split(":")
            assert (cls.__module__, cls.__name__, cls.name) == (module, attr, name)
            path = module.replace(".", "/") + ".py"
            assert path in modules and f"tests/test_{Path(path).name}" in tests, path
    assert len(modules) == len(tests) == 7
    # every test of the page runs and passes
    ran = []
    for path in sorted(tests):
        for fname, fn in runpy.run_path(str(extras_installed / path)).items():
            if fname.startswith("test_") and callable(fn):
                fn()
                ran.append(fname)
    assert len(ran) == 12, ran


def test_the_backend_plugins_get_run_wide_settings_and_one_line_errors(extras_installed):
    from pydantic import ValidationError

    from graphseg.pipeline import resolve_backend, resolve_backends
    from graphseg.scene import SceneError

    assert resolve_backend("matcher", "orb", Config(backends={"num_matches": 77})).options.num_matches == 77  # a declared field
    cfg = Config(backends={"segmenter": "colour_regions", "options": {"colour_regions": {"levles": 3}}})
    with pytest.raises(SceneError) as err:
        resolve_backends(cfg)
    assert str(err.value) == "backends.options.colour_regions.levles: unknown option 'levles'; valid keys: levels, min_area; did you mean 'levels'?"
    assert str(err.value) in (DOCS / "plugins.md").read_text().replace("\n", " ")
    with pytest.raises(ValidationError, match="label_propagation: unknown option 'max_round'; valid options: max_rounds; did you mean 'max_rounds'"):
        Config(contractor={"label_propagation": {"max_round": 100}})


def test_architecture_page_points_to_the_tutorial():
    text = (DOCS / "architecture.md").read_text()
    assert "plugins.md" in text and "adder_options" not in text


def _extras_closure(optional, names):
    """The requirement strings of the extras ``names``, following graphseg[...] self-references."""
    out, todo, seen = [], list(names), set()
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        seen.add(name)
        for req in optional.get(name, []):
            if m := re.fullmatch(r"graphseg\[(.+)\]", req.replace(" ", "")):
                todo += m.group(1).split(",")
            else:
                out.append(req)
    return out


def test_readme_says_which_commands_need_torch():
    """Issue 19: the README told every user to install torch first; only some extras pull it."""
    root = Path(__file__).resolve().parents[1]
    readme = (root / "README.md").read_text()
    optional = tomllib.loads((root / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    main = readme.split("<!-- main-command -->", 1)[1].split("```", 2)[1]
    extras = re.search(r'pip install "\.\[([\w,]+)\]"', main).group(1).split(",")
    assert not any(r.startswith("torch") for r in _extras_closure(optional, extras)), main
    assert "This command needs no torch" in readme
    para = readme[readme.index("**torch first.**"):].split("\n\n", 1)[0]
    named = re.findall(r"`(\w+)`", para.split("Before any of them")[0])
    free = re.findall(r"`(\w+)`", para.split("The main")[1])
    pulls = {e for e in optional if any(r.startswith("torch") for r in _extras_closure(optional, [e]))}
    assert set(named) == pulls, (named, pulls)
    assert free and not set(free) & pulls, (free, pulls)


ROOT = Path(__file__).resolve().parents[1]
#: The pages a reader follows; docs/history.md is the round-by-round record and may keep old paths.
PAGES = [ROOT / "README.md", *sorted(p for p in DOCS.glob("*.md") if p.name != "history.md")]
CPU_TORCH = "pip install torch==2.13.0 --extra-index-url https://download.pytorch.org/whl/cpu"


def _fenced(readme, marker):
    """The single line of the fenced block right after ``<!-- marker -->``."""
    block = readme.split(f"<!-- {marker} -->\n", 1)[1]
    m = re.match(r"```bash\n(.*?)\n```", block, flags=re.S)
    assert m, f"no ```bash fence right after <!-- {marker} -->"
    return m.group(1)


def test_readme_is_a_short_page_with_its_two_commands():
    """Issue 52: the README is a newcomer's page; `.ci/run` runs its two commands as written."""
    readme = (ROOT / "README.md").read_text()
    assert len(readme.splitlines()) <= 150
    assert _fenced(readme, "main-command") == 'pip install ".[sim]" && graphseg demo -o graphseg-demo'
    assert _fenced(readme, "test-command") == (
        f"{CPU_TORCH} && pip install -e \".[test]\" && SAM2_BUILD_CUDA=0 pip install --no-deps --no-build-isolation"
        " --upgrade --target .test-models -r requirements/no-deps.txt && python -m pytest"
    )
    for needed in ('nx.connected_components(G, backend="graphseg")', "YCB-Video", "GraspNet-1Billion", "BOP", "../shared/data/ycbv"):
        assert needed in readme, needed
    for doc in DOCS.glob("*.md"):  # an index line for every page of docs/
        assert f"(docs/{doc.name})" in readme, doc.name


def test_every_torch_install_hint_gives_the_cpu_build():
    """Issue 52: `pip install torch==2.13.0` alone fetches the CUDA build on an ordinary machine."""
    for page in [*PAGES, DOCS / "history.md"]:
        text = " ".join(page.read_text().split())  # lines joined: a hint may wrap
        for m in re.finditer(r"pip install torch==2\.13\.0", text):
            assert text[m.start() :].startswith(CPU_TORCH), f"{page.name}: {text[m.start() : m.start() + 80]}"


def test_doc_links_and_cited_result_files_exist():
    """Issue 52: every link of the README and docs/ leads to a file; every cited result file is there."""
    for page in [*PAGES, DOCS / "history.md"]:
        text = page.read_text()
        for target in re.findall(r"\]\(([^)\s]+)\)", text):
            if re.match(r"[a-z]+:", target) or target.startswith("#"):
                continue
            assert (page.parent / target.split("#")[0]).exists(), f"{page.name}: broken link {target}"
        if page.name == "history.md":  # the record may name files as they were then
            continue
        for cited in re.findall(r"benchmarks/results/[\w.{},*/-]*[\w}]", text):
            m = re.search(r"\{([^}]*)\}", cited)
            names = [cited[: m.start()] + alt + cited[m.end() :] for alt in m.group(1).split(",")] if m else [cited]
            for name in names:
                assert list(ROOT.glob(name)), f"{page.name}: {name} does not exist"


def test_results_page_is_current_and_short():
    """Issue 52: docs/results.md holds the current results with their commands; the rounds are in history.md."""
    text = (DOCS / "results.md").read_text()
    assert len(text.splitlines()) <= 400
    assert "removing 1% of the points moves a ycb half mean by up to 0.017" in " ".join(text.lower().split())
    assert "## What is still weak" in text and "(history.md)" in text
    assert (DOCS / "history.md").read_text().count("### Round") > 40
    # every bench script a command names exists and takes the flags given to it
    for line in re.findall(r"python (benchmarks/\w+\.py[^\n`|]*)", text):
        script, *args = line.split()
        source = (ROOT / script).read_text()
        for flag in (a for a in args if a.startswith("--")):
            assert f'"{flag}"' in source, f"{script} has no {flag}"
