"""Run (or resume) a campaign, one step after the other:

1. load the campaign (:mod:`.campaign`);
2. prepare the output folder (:mod:`.folder`);
3. prepare the FMU (:mod:`.fmu_setup`);
4. write the truth (:mod:`.truth`);
5. schedule the tests on the workers (:mod:`.schedule`, :mod:`.pool`);
6. write the traces as they come back (:mod:`.folder`).
"""
from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from structbench.fmus import default_fmu_dir
from structbench.models.errors import UserError

from .campaign import Campaign, load_campaign
from .fmu_setup import prepare_fmu
from .folder import CampaignStatus, Folder
from .pool import make_pool
from .schedule import Scheduler
from .step_check import check_only, run_step_check
from .prior import write_prior
from .truth import truth

Progress = Callable[[CampaignStatus], None]


def run_campaign(campaign: Campaign | str | Path, out: str | Path | None, jobs: int | None = None,
                 scheduler: str | None = None, fmu_dir: str | Path | None = None,
                 progress: Progress | None = None, check_step: str = "auto") -> CampaignStatus:
    """Run (or resume) a campaign into the folder ``out``.

    ``jobs``: local worker processes (default one per CPU; 0 runs in this
    process); ``scheduler``: address of a Dask scheduler instead; ``fmu_dir``:
    where a built-in structure's FMU is built (default ``out/fmus``);
    ``progress`` is called with the status after every finished task.
    Everything is validated before the first simulation. Returns the final
    status; ``status.failed`` tests are listed with their errors in
    ``out/status.json``.

    ``check_step``: ``"auto"`` runs the step-convergence check
    (:mod:`.step_check`) of an external FMU before the tests, its warnings in
    ``status.warnings`` and ``status.json``; ``"only"`` runs just that check
    on any FMU and writes nothing (``out`` may be None; a built-in structure's
    FMU is built into ``fmu_dir``, default ``$STRUCTBENCH_FMU_DIR`` or
    ``~/.cache/structbench/fmus``); ``"off"`` skips it.
    """
    if not isinstance(campaign, Campaign):
        campaign = load_campaign(campaign)
    if check_step not in ("auto", "only", "off"):
        raise UserError(f"expected auto, only or off, got {check_step!r}", field="check_step")
    if check_step == "only":
        return check_only(campaign, Path(fmu_dir) if fmu_dir else (Path(out) / "fmus" if out else default_fmu_dir()),
                          jobs, scheduler)
    folder = Folder(out)
    folder.prepare(campaign)
    bench = prepare_fmu(campaign, Path(fmu_dir) if fmu_dir else folder.root / "fmus")
    folder.write_truth(truth(campaign))
    write_prior(folder.root, campaign.prior, campaign.true_model)  # [prior]: DIR/prior.json
    status = folder.status(campaign, bench)
    folder.write_status(status)
    pool = make_pool(jobs, scheduler)
    try:
        blob = pool.share_fmu(Path(bench.fmu))
        if check_step == "auto" and bench.options.external:  # the step check (step_check.py)
            status.warnings = run_step_check(pool, bench, campaign.tests[0], blob)
            folder.write_status(status)
        tasks = Scheduler(pool, bench, folder, status, blob, progress)
        tasks.plan(campaign.tests)
        if progress is not None:
            progress(status)
        tasks.run()
    finally:
        pool.close()
        folder.remove_partial()  # writes cut short when a worker was killed
        folder.write_status(status)  # what was booked, also when the run was interrupted
    return status
