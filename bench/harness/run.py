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

from .campaign import Campaign, load_campaign
from .fmu_setup import prepare_fmu
from .folder import CampaignStatus, Folder
from .pool import make_pool
from .schedule import Scheduler
from .prior import write_prior
from .truth import truth

Progress = Callable[[CampaignStatus], None]


def run_campaign(campaign: Campaign | str | Path, out: str | Path, jobs: int | None = None,
                 scheduler: str | None = None, fmu_dir: str | Path | None = None,
                 progress: Progress | None = None) -> CampaignStatus:
    """Run (or resume) a campaign into the folder ``out``.

    ``jobs``: local worker processes (default one per CPU; 0 runs in this
    process); ``scheduler``: address of a Dask scheduler instead; ``fmu_dir``:
    where a built-in structure's FMU is built (default ``out/fmus``);
    ``progress`` is called with the status after every finished task.
    Everything is validated before the first simulation. Returns the final
    status; ``status.failed`` tests are listed with their errors in
    ``out/status.json``.
    """
    if not isinstance(campaign, Campaign):
        campaign = load_campaign(campaign)
    folder = Folder(out)
    folder.prepare(campaign)
    bench = prepare_fmu(campaign, Path(fmu_dir) if fmu_dir else folder.root / "fmus")
    folder.write_truth(truth(campaign))
    write_prior(folder.root, campaign.prior, campaign.true_model)  # [prior]: DIR/prior.json
    status = folder.status(campaign, bench)
    folder.write_status(status)
    pool = make_pool(jobs, scheduler)
    try:
        tasks = Scheduler(pool, bench, folder, status, pool.share_fmu(Path(bench.fmu)), progress)
        tasks.plan(campaign.tests)
        if progress is not None:
            progress(status)
        tasks.run()
    finally:
        pool.close()
        folder.remove_partial()  # writes cut short when a worker was killed
        folder.write_status(status)  # what was booked, also when the run was interrupted
    return status
