"""structbench's pytest plugin (entry point group ``pytest11``, name
``structbench``): campaigns run once into a content-addressed cache, and
assertions of a campaign's ``[check]`` gates (docs/ci.md).

Fixtures: ``structbench_cache`` (the cache folder) and
``structbench_campaign`` (a factory: ``structbench_campaign("frame.toml")``
returns a folder holding that campaign's traces, run at most once per
session and, with the cache kept, once per cache key at all). Helper:
:func:`assert_gates` identifies with a method, built-in or plugin, and
asserts every gate of the campaign for its results.

The cache key is the sha256 of the campaign file's text, the FMU's sha256 and
structbench's version; an entry is the campaign's output folder
``<cache>/<key>/`` with ``<key>.json`` beside it once every test is done. The
cache is ``--structbench-cache DIR``, else the ini option
``structbench_cache`` (relative to the rootdir), else ``$STRUCTBENCH_CACHE``,
else ``~/.cache/structbench/campaigns``.

Loaded into every pytest run of the environment it is installed in, this
module only registers options and fixtures: it imports structbench's
simulation and identification code (numpy, fmpy, h5py ...) when a fixture
or helper is used, never at import.
"""
from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
import tomllib
from collections.abc import Callable, Iterator, Sequence
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import pytest

CACHE_ENV = "STRUCTBENCH_CACHE"
DEFAULT_CACHE = Path("~/.cache/structbench/campaigns")
CACHE_FORMAT = "structbench-campaign-cache"
SOURCE_FILE = "pytest-source.json"  # in a session's working folder: where its campaign came from


def pytest_addoption(parser: pytest.Parser) -> None:
    """``--structbench-cache DIR`` and ``--structbench-jobs N`` (and their ini options)."""
    group = parser.getgroup("structbench", "structbench campaigns (structbench.pytest_plugin)")
    group.addoption("--structbench-cache", metavar="DIR", default=None,
                    help=f"campaign cache folder (default: ini structbench_cache, ${CACHE_ENV}, {DEFAULT_CACHE})")
    group.addoption("--structbench-jobs", metavar="N", type=int, default=None,
                    help="worker processes of a campaign run (default: ini structbench_jobs, else one per core; "
                         "0: in the test process)")
    parser.addini("structbench_cache", "campaign cache folder, relative to the rootdir", default="")
    parser.addini("structbench_jobs", "worker processes of a campaign run (0: in the test process)", default="")


def cache_dir(config: pytest.Config) -> Path:
    """The cache folder this session uses (see the module's docstring)."""
    given = config.getoption("structbench_cache", None)
    if given:
        return Path(given).expanduser().absolute()
    ini = str(config.getini("structbench_cache") or "")
    if ini:
        return (config.rootpath / Path(ini).expanduser()).absolute()
    return Path(os.environ.get(CACHE_ENV) or DEFAULT_CACHE).expanduser().absolute()


def _jobs(config: pytest.Config) -> int | None:
    given = config.getoption("structbench_jobs", None)
    if given is not None:
        return int(given)
    ini = str(config.getini("structbench_jobs") or "").strip()
    if not ini:
        return None
    try:
        return int(ini)
    except ValueError:
        raise pytest.UsageError(f"ini option structbench_jobs: expected a whole number, got {ini!r}") from None


def cache_key(campaign_text: str, fmu_sha256: str, version: str, signals: Sequence[str] = ()) -> str:
    """sha256 (hex) of the campaign file's text, the FMU's sha256 and
    structbench's version (and the sha256 of the recorded signals the
    campaign's excitation reads from files, which its text only names)."""
    digest = hashlib.sha256(CACHE_FORMAT.encode())
    for part in (campaign_text, fmu_sha256, version, *signals):
        data = part.encode()
        digest.update(len(data).to_bytes(8, "big") + data)
    return digest.hexdigest()


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version("structbench")
    except PackageNotFoundError:
        return "unknown"


@contextlib.contextmanager
def _locked(path: Path) -> Iterator[None]:
    """Hold an exclusive lock on ``path`` (parallel sessions, e.g. pytest-xdist
    workers, share one cache); without ``fcntl`` (Windows) no lock."""
    try:
        import fcntl
    except ImportError:
        yield
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def _complete(entry: Path) -> bool:
    """Every test of the entry done and every trace file as its status booked it."""
    try:
        status = json.loads((entry / "status.json").read_text())
        tests = status["tests"].values()
        if any(t["state"] != "done" for t in tests):
            return False
        return all(_sha256(entry / "traces" / name) == digest for t in tests for name, digest in t["sha256"].items())
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return False


def _failures(status: Any) -> str:
    return "; ".join(f"{t.name}: {t.error}" for t in status.tests.values() if t.error) or "tests left pending"


def cached_campaign(campaign_file: str | Path, cache: str | Path, jobs: int | None = None) -> Path:
    """The output folder of ``campaign_file`` in ``cache``: reused when its
    entry is complete (nothing simulated), else run (or resumed) into it."""
    import structbench as sb
    from structbench.fmus import build_fmu

    cache = Path(cache)
    campaign = sb.load_campaign(campaign_file)  # validated: a bad file fails here, naming file and line
    if campaign.fmu is not None:
        fmu = campaign.fmu
    else:
        with _locked(cache / "fmus.lock"):
            fmu = build_fmu(campaign.model, cache / "fmus")  # a no-op when already built
    fmu_sha256 = _sha256(fmu)
    signals = sorted({i.sha256 for t in campaign.tests for i in t.excitation if hasattr(i, "sha256")})
    key = cache_key(campaign.text, fmu_sha256, _version(), signals)
    entry, marker = cache / key, cache / f"{key}.json"
    with _locked(cache / f"{key}.lock"):
        if marker.is_file() and _complete(entry):
            return entry
        marker.unlink(missing_ok=True)
        status = sb.run_campaign(campaign, entry, jobs=jobs, fmu_dir=cache / "fmus")
        if status.failed or not _complete(entry):
            raise RuntimeError(f"campaign {campaign.name} ({campaign_file}) did not complete in {entry}: "
                               f"{_failures(status)}")
        info = {"format": CACHE_FORMAT, "key": key, "campaign": campaign.name,
                "campaign_sha256": hashlib.sha256(campaign.text.encode()).hexdigest(), "fmu_sha256": fmu_sha256,
                "structbench": _version(), "created": datetime.now(timezone.utc).isoformat(timespec="seconds")}
        partial = marker.with_suffix(".json.partial")
        partial.write_text(json.dumps(info, indent=1) + "\n")
        os.replace(partial, marker)
    return entry


def working_folder(entry: Path, target: Path, campaign_file: Path) -> Path:
    """A folder that reads as the cached campaign folder ``entry`` (its traces
    linked, not copied, where links work) with a results folder of its own,
    so that identification never writes into the cache."""
    target.mkdir(parents=True)
    for name in ("campaign.toml", "truth.json", "status.json"):
        if (entry / name).exists():
            shutil.copy2(entry / name, target / name)
    try:
        (target / "traces").symlink_to(entry / "traces", target_is_directory=True)
    except OSError:
        shutil.copytree(entry / "traces", target / "traces")
    ref = tomllib.loads((entry / "campaign.toml").read_text(encoding="utf-8")).get("structure", "")
    model = campaign_file.parent / ref if isinstance(ref, str) and ref.endswith(".toml") else None
    source = {"campaign": str(campaign_file), "cache": str(entry),
              "model": str(model.resolve()) if model is not None and model.is_file() else None}
    (target / SOURCE_FILE).write_text(json.dumps(source, indent=1) + "\n")
    return target


@pytest.fixture(scope="session")
def structbench_cache(pytestconfig: pytest.Config) -> Path:
    """The campaign cache folder of this session."""
    return cache_dir(pytestconfig)


@pytest.fixture(scope="session")
def structbench_campaign(pytestconfig: pytest.Config, tmp_path_factory: pytest.TempPathFactory,
                         structbench_cache: Path) -> Callable[..., Path]:
    """``structbench_campaign(path, jobs=None)``: a folder with the traces of
    the campaign file ``path`` (relative to the rootdir), from the cache or
    run into it; the same folder for every test of the session."""
    made: dict[Path, Path] = {}

    def campaign(path: str | Path, jobs: int | None = None) -> Path:
        file = (pytestconfig.rootpath / Path(path).expanduser()).resolve()
        if not file.is_file():
            raise FileNotFoundError(f"structbench_campaign: no campaign file {path} (looked for {file})")
        if file not in made:
            entry = cached_campaign(file, structbench_cache, jobs if jobs is not None else _jobs(pytestconfig))
            made[file] = working_folder(entry, tmp_path_factory.mktemp("structbench") / file.stem, file)
        return made[file]

    return campaign


def assert_gates(folder: str | Path, method: str, *, tag: str | None = None, model: str | Path | None = None,
                 groups: Sequence[str] | None = None, jobs: int | None = None, **options: Any) -> list[dict[str, Any]]:
    """Identify the runs of ``folder`` with ``method`` (options as keywords;
    results ``<method>[-<tag>].json``), score them and assert every
    ``[check]`` gate that applies to those results; a failure lists each
    gate with its value, threshold and campaign. Returns the gate rows."""
    import structbench as sb
    from structbench.evaluation.junit import failure_message

    folder = Path(folder)
    source = folder / SOURCE_FILE
    chosen = sb.methods().get(method)  # an unknown name: identify says so
    if model is None and source.is_file() and chosen is not None and chosen.model != "none":
        model = json.loads(source.read_text()).get("model")
    sb.identify(folder, method, model=model, groups=groups, tag=tag, jobs=jobs, **options)
    stem = sb.results_file(folder, method, tag).stem
    rows = sb.check(folder, results=[stem])
    failed = [r for r in rows if not r["ok"]]
    if failed:
        where = json.loads(source.read_text())["campaign"] if source.is_file() else str(folder)
        lines = [f"{'PASS' if r['ok'] else 'FAIL'}  {failure_message(r)}" for r in rows]
        pytest.fail(f"{len(failed)} of {len(rows)} [check] gates failed for {stem} (method {method}) "
                    f"on {where}:\n" + "\n".join(lines), pytrace=False)
    return rows
