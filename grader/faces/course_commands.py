"""The instructor's commands of `grade`: release, batch, worker, gradescope, regrade and selftest."""

from __future__ import annotations

import os
import sys

import click

from grader.faces.options import (
    EXIT_ALL_PASSED,
    EXIT_NOT_ALL_PASSED,
    EXIT_USAGE,
    chapters_option,
    handout_id,
    instructor_course,
    instructor_side,
)
from grader.render import plural


@click.command("release")
@click.argument("out", type=click.Path(file_okay=False))
@click.option("--course", "course_file", type=click.Path(exists=True, dir_okay=False), default=None,
              help="The course configuration (default: solutions/course.yaml beside the references).")
@click.option("--force", is_flag=True, help="Replace what OUT holds.")
@click.option("--no-classroom", is_flag=True,
              help="Leave out the GitHub Classroom workflow (.github/workflows/classroom.yml).")
@click.option("--notebooks", is_flag=True,
              help="Each chapter's stub as a Jupyter notebook (exercises/chNN_*.ipynb, for Jupyter and Colab) "
                   "instead of a .py: install cell, text as markdown, a cell per function, %grade last.")
@click.option("--pip-source", default=None, metavar="SPEC",
              help="What the notebooks' first cell installs where the grader is missing, e.g. the wheel's URL "
                   "for Colab (default: the wheel beside exercises/).")
def release_command(out: str, course_file: str | None, force: bool, no_classroom: bool, notebooks: bool,
                    pip_source: str | None) -> None:
    """Build the learners' handout in OUT: stubs, answer templates, the grader as a wheel, a README and a
    GitHub Classroom workflow; no reference solution, quiz key or reference answer in any of it."""
    from pathlib import Path

    from grader.course import release

    the_course = instructor_course(course_file, "grade release")
    try:
        built = release.build(Path(out), the_course, force=force, notebooks=notebooks, pip_source=pip_source,
                              classroom=not no_classroom)
    except release.OutNotEmpty as exc:
        raise click.BadParameter(str(exc), param_hint="OUT") from None
    except release.ReleaseError as exc:
        raise click.ClickException(f"{exc}\n{out} is left as it was.") from None
    click.echo(release.describe(built))
    if not no_classroom:
        from grader.course import classroom

        click.echo(f"GitHub Classroom: {Path(out) / classroom.WORKFLOW} runs `grade classroom all` on every push of a "
                   "learner's repository and reports each check's points (use OUT as the assignment's template "
                   "repository).")


@click.command("batch")
@click.argument("submissions", type=click.Path(exists=True, file_okay=False))
@click.option("--out", "out_dir", type=click.Path(file_okay=False), required=True, help="Output folder.")
@click.option("--roster", type=click.Path(exists=True, dir_okay=False), default=None,
              help="CSV with columns submission,learner mapping folder/zip names to learner ids (',' or ';').")
@click.option("--chapters", "chapter_list", default="all", show_default=True, help="e.g. ch05,ch06")
@click.option("--jobs", type=click.IntRange(min=1), default=None, help="Parallel workers (default: all cores).")
@click.option("--seed", type=int, default=None,
              help="Seed for the random test inputs (default: the course seed of solutions/course.yaml).")
@click.option("--course", "course_file", type=click.Path(exists=True, dir_okay=False), default=None,
              help="The course configuration (default: solutions/course.yaml beside the references).")
@click.option("--no-html", is_flag=True, help="Skip the per-learner report.html.")
@click.option("--plots", is_flag=True, help="Draw plots in each report.html (about 0.5 s of CPU per learner).")
@click.option("--no-sandbox", is_flag=True,
              help="Run learner code without bubblewrap even where it is installed (the isolation line says so).")
@click.option("--time-budget", type=click.FloatRange(min=1), default=60, show_default=True,
              help="Seconds for one learner's code, all chapters together; the quiz gets what is left.")
@click.option("--lms", "lms_layouts", type=click.Choice(["canvas", "moodle"]), multiple=True,
              help="Also write the gradebook as that system imports it: gradebook-canvas.csv, gradebook-moodle.csv "
                   "(repeat for both).")
@click.option("--overrides", "overrides_file", type=click.Path(dir_okay=False), default=None,
              help="Overrides (learner,target,points,factor,reason,who) applied on every run (default: "
                   "OUT/overrides.csv where it exists).")
@click.option("--handout", "handout", default=None,
              help="The current handout: its id, or the folder grade release wrote (its handout.json); archives "
                   "packed with another are flagged (default: the course config's `handout:`).")
@click.option("--similarity", is_flag=True,
              help="Rank pairs of learners by how alike their code is (copydetect), for a person to look at.")
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="Grade on a Dask cluster: its scheduler, e.g. tls://host:8786, whose workers run `grade worker` "
                   "(default: $DASK_SCHEDULER_ADDRESS, else the course file's `scheduler:`; `local`: this machine's "
                   "pool). Needs the [cluster] extra.")
@click.option("--certs", type=click.Path(file_okay=False), default=None, metavar="DIR",
              help="The cluster's certificates (`grade cluster certs DIR`: ca.pem and coordinator.pem here; default: "
                   "the course file's `scheduler: {certs: DIR}`, else Dask's own TLS settings).")
@click.option("--insecure-open-cluster", "open_cluster", is_flag=True,
              help="Grade on a scheduler without TLS: anyone who reaches its port can then run code on the workers, "
                   "read the references and rewrite grades.")
def batch_command(submissions: str, out_dir: str, roster: str | None, chapter_list: str, jobs: int | None,
                  seed: int | None, course_file: str | None, no_html: bool, plots: bool, no_sandbox: bool,
                  time_budget: float, lms_layouts: tuple[str, ...], overrides_file: str | None, handout: str | None,
                  similarity: bool, scheduler: str | None, certs: str | None, open_cluster: bool) -> None:
    """Grade a folder of submissions (folders or .zip files) into a gradebook and per-learner reports,
    at the course seed, hidden checks included; keep every run in OUT/gradebook.db and say in
    OUT/changes.csv whose score moved and why."""
    import dataclasses
    from pathlib import Path

    from grader.course import batch
    from grader.safe_text import for_terminal

    picked = chapters_option(chapter_list)
    the_course = instructor_course(course_file, "grade batch")
    if handout is not None:
        the_course = dataclasses.replace(the_course, current_handout=handout_id(handout))
    if similarity:
        from grader.course import similarity as similarities

        try:
            similarities._engine()
        except similarities.SimilarityUnavailable as exc:
            raise click.UsageError(str(exc)) from None
    pool = _cluster_pool(scheduler, the_course, jobs, certs, open_cluster)
    try:
        result = batch.run_batch(Path(submissions), Path(out_dir), chapters=[c.id for c in picked],
                                 roster=Path(roster) if roster else None, jobs=jobs,
                                 seed=the_course.grading_seed if seed is None else seed,
                                 seed_from="--seed" if seed is not None else the_course.where("seed"),
                                 html=not no_html, plots=plots, limits={"learner_seconds": time_budget},
                                 sandboxed=not no_sandbox, progress=batch.progress_bar(), hidden=the_course.hidden,
                                 lms_layouts=tuple(lms_layouts), course=the_course,
                                 overrides=Path(overrides_file) if overrides_file else None, similarity=similarity,
                                 announce=lambda line: click.echo(line, err=True), pool=pool)
    except batch.RosterError as exc:
        raise click.BadParameter(for_terminal(str(exc)), param_hint="--roster") from None
    except batch.OverridesError as exc:
        raise click.BadParameter(for_terminal(str(exc)), param_hint="--overrides") from None
    except batch.NoSubmissions as exc:
        raise click.BadParameter(for_terminal(str(exc), one_line=True), param_hint="SUBMISSIONS") from None
    except batch.InfrastructureError as exc:
        if pool is not None:  # the cluster cannot grade (grader.course.cluster.ClusterError): the message says why
            click.echo(f"grade batch: no learner was graded: {for_terminal(str(exc), one_line=True)}", err=True)
            sys.exit(EXIT_USAGE)
        from grader.boundary import how_to_get_a_barrier, without_a_sandbox

        click.echo(f"grade batch: no learner was graded: learner code cannot run here behind a barrier. "
                   f"{for_terminal(str(exc), one_line=True)}\nTo grade: {how_to_get_a_barrier()}; "
                   f"{without_a_sandbox()}.", err=True)
        sys.exit(EXIT_USAGE)
    _say_batch(result, Path(out_dir), Path(roster).name if roster else "the roster")
    sys.exit(EXIT_ALL_PASSED if result.complete else EXIT_NOT_ALL_PASSED)


def _say_batch(result, out, roster: str) -> None:
    """What a batch did, for the instructor: counts, who is not graded and why, who is flagged, what was skipped,
    where the roster and the folder disagree, the notes, what moved, the alike pairs, the isolation line."""
    from grader.render.summary import change_text
    from grader.safe_text import for_terminal

    def said(line: str) -> None:
        click.echo(f"  {for_terminal(line, one_line=True)}", err=True)

    counts = ", ".join(f"{n} {status}" for status, n in sorted(result.counts.items()))
    skipped = f"; {len(result.skipped)} skipped" if result.skipped else ""
    flagged = f"; {len(result.flagged)} flagged" if result.flagged else ""
    rows = sum(u.kind == "row" for u in result.unmatched)
    unmatched = (f"; {plural(rows, 'roster row')} naming no submission" if rows else "") + (
        f"; {plural(len(result.unmatched) - rows, 'submission')} no roster row names" if len(result.unmatched) > rows
        else "")
    click.echo(f"{plural(len(result.statuses), 'submission')}: {counts or 'none'}{skipped}{flagged}{unmatched}; graded "
               f"{result.graded_now} in {result.seconds:.1f} s. Gradebook: {out / 'gradebook.csv'}")
    for learner, message in sorted(result.messages.items()):
        if result.statuses[learner] in ("error", "unreadable"):
            said(f"{learner}: {message}")
    still_flagged = 0
    for learner, warnings in sorted(result.flagged.items()):
        if result.statuses.get(learner) != "graded":  # unchanged since a run that listed its flags
            still_flagged += 1
            continue
        for warning in warnings:
            said(f"flagged {learner}: {warning}")
    if still_flagged:
        click.echo(f"  {plural(still_flagged, 'learner')} not graded again this run still flagged (as listed before; "
                   f"all in {out / 'summary.html'})", err=True)
    for entry in result.skipped:
        said(f"skipped {entry.name}: {entry.reason}")
    for unmatched_one in result.unmatched:
        said(unmatched_one.describe(roster))
    for note in result.override_problems + result.notes:
        said(note)
    if result.first_run:
        click.echo(f"The history's first run: {plural(len(result.changes), 'learner')} graded first: "
                   f"{out / 'changes.csv'}")
    else:
        click.echo(f"{plural(len(result.changes), 'score')} moved since the last run: {out / 'changes.csv'}")
        for change in result.changes[:10]:
            said(f"{change[0]}: {change_text(change)}")
    for pair in result.similar[:5]:
        click.echo(f"  alike: {for_terminal(pair.first, one_line=True)} and {for_terminal(pair.second, one_line=True)} "
                   f"({pair.score:.2f}; {', '.join(pair.functions[:3])}): for a person to look at, in summary.html")
    click.echo(result.isolation, err=True)


def _cluster_pool(option: str | None, the_course, jobs: int | None, certs: str | None, open_cluster: bool):
    """The pool grade batch grades through: None (this machine's, grader.course.batch.LocalPool), or a
    grader.course.cluster.ClusterPool on the scheduler that --scheduler, else $DASK_SCHEDULER_ADDRESS, else the course
    file's `scheduler:` names (`local`: this machine's), with the certificates of --certs, else the course file's."""
    for address, origin in ((option, "--scheduler"), (os.environ.get("DASK_SCHEDULER_ADDRESS"), "DASK_SCHEDULER_ADDRESS"),
                            (the_course.scheduler, the_course.where("scheduler"))):
        if address:
            break
    if not address or address.strip() == "local":
        return None
    if jobs is not None:
        raise click.UsageError(f"--jobs sizes this machine's pool, but the learners are graded on the cluster at {address} "
                               f"({origin}); pass --scheduler local to grade here")
    from grader.course import cluster, credentials
    from grader.safe_text import for_terminal

    folder = certs or the_course.scheduler_certs
    try:
        security = credentials.security(folder, "coordinator") if folder else None
    except credentials.CredentialsError as exc:
        raise click.BadParameter(for_terminal(str(exc), one_line=True),
                                 param_hint="--certs" if certs else the_course.where("scheduler")) from None
    except ImportError:
        raise click.UsageError(f"grading on a cluster needs Dask: {cluster.INSTALL_HINT}") from None
    return cluster.ClusterPool(address.strip(), security=security, open_cluster=open_cluster,
                               say=lambda line: click.echo(f"  {for_terminal(line, one_line=True)}", err=True))


@click.command("worker", context_settings={"ignore_unknown_options": True})
@click.argument("scheduler")
@click.option("--certs", type=click.Path(file_okay=False), default=None, metavar="DIR",
              help="The cluster's certificates (`grade cluster certs DIR`: ca.pem and worker.pem here).")
@click.option("--nworkers", type=click.IntRange(min=1), default=None,
              help="Worker processes, each grading one learner at a time (default: one per core).")
@click.option("--insecure-open-cluster", "open_cluster", is_flag=True,
              help="Join a scheduler without TLS: anyone who reaches its port can then run code on this worker.")
@click.option("--no-sandbox", is_flag=True, hidden=True)
@click.argument("dask_options", nargs=-1, type=click.UNPROCESSED)
def worker_command(scheduler: str, certs: str | None, nworkers: int | None, open_cluster: bool, no_sandbox: bool,
                   dask_options: tuple[str, ...]) -> None:
    """Grade for `grade batch --scheduler SCHEDULER` on this machine: join the Dask scheduler as worker processes
    (`dask worker`; further options, e.g. --memory-limit 4GB, go to it), over TLS with the course's certificates.
    Refuses to start where learner code cannot run behind a barrier (bubblewrap, or as root an unprivileged user
    of its own), where the connection is not encrypted, or where this grader is not the running coordinator's
    version."""
    from pathlib import Path

    from grader.course import cluster, credentials
    from grader.safe_text import for_terminal

    def refuse(why: str) -> None:
        click.echo(f"grade worker: not started: {for_terminal(why, one_line=True)}", err=True)
        sys.exit(EXIT_USAGE)

    if no_sandbox:
        refuse("a worker never runs learner code without a barrier (learner code there could take over the cluster "
               "and every grade on it); where bubblewrap cannot start, run the worker as root with a user "
               "grader-learner of its own (`useradd --system --no-create-home --shell /usr/sbin/nologin grader-learner`)")
    folder = Path(certs).expanduser() if certs else None
    try:
        isolation = cluster.prepare_worker(scheduler, folder, open_cluster)
        command = cluster.worker_command(scheduler, nworkers, dask_options, folder)
    except (cluster.WorkerRefused, credentials.CredentialsError) as exc:
        refuse(str(exc))
    click.echo(f"grade worker: grader {cluster.grader_version()}, joining {scheduler}\n{isolation}", err=True)
    cluster.become(command, cluster.worker_environment(folder, open_cluster))


@click.group("cluster")
def cluster_group() -> None:
    """A Dask cluster of the course's own: its certificates and its scheduler (mutual TLS: only machines holding the
    course's certificates join it)."""


@cluster_group.command("certs")
@click.argument("folder", type=click.Path(file_okay=False))
@click.option("--days", type=click.IntRange(min=1), default=365, show_default=True,
              help="How long the certificates are valid.")
@click.option("--force", is_flag=True, help="Replace the certificates FOLDER holds.")
def cluster_certs_command(folder: str, days: int, force: bool) -> None:
    """Make the cluster's certificates in FOLDER: a certificate authority of the course's own (ca.pem; its key is not
    kept) and a certificate with its key for the scheduler, the workers and the coordinator (ROLE.pem, readable by
    you only)."""
    from pathlib import Path

    from grader.course import credentials

    try:
        written = credentials.make(Path(folder).expanduser(), days=days, force=force)
    except credentials.CredentialsError as exc:
        raise click.ClickException(str(exc)) from None
    click.echo(credentials.describe(written))


@cluster_group.command("scheduler", context_settings={"ignore_unknown_options": True})
@click.option("--certs", type=click.Path(file_okay=False), required=True, metavar="DIR",
              help="The cluster's certificates (ca.pem and scheduler.pem here).")
@click.option("--host", default="", help="The interface to listen on (default: every one).")
@click.option("--port", type=click.IntRange(min=0, max=65535), default=8786, show_default=True)
@click.argument("dask_options", nargs=-1, type=click.UNPROCESSED)
def cluster_scheduler_command(certs: str, host: str, port: int, dask_options: tuple[str, ...]) -> None:
    """Run the cluster's Dask scheduler: TLS only, every connection showing a certificate of the course's authority,
    its dashboard on this machine only (127.0.0.1:8787). Further options go to `dask scheduler`."""
    from pathlib import Path

    from grader.course import cluster, credentials

    try:
        cluster.distributed_module()
        tls = credentials.dask_options(Path(certs).expanduser(), "scheduler")
    except (cluster.ClusterError, credentials.CredentialsError) as exc:
        raise click.ClickException(str(exc)) from None
    command = [sys.executable, "-m", "distributed.cli.dask_scheduler", "--protocol", "tls", "--port", str(port),
               *(["--host", host] if host else []), "--dashboard-address", "127.0.0.1:8787", *tls, *dask_options]
    cluster.become(command, credentials.require_encryption_environment())


@click.command("gradescope")
@click.argument("out", type=click.Path(dir_okay=False))
@click.option("--course", "course_file", type=click.Path(exists=True, dir_okay=False), default=None,
              help="The course configuration (default: solutions/course.yaml beside the references).")
@click.option("--chapters", "chapter_list", default="all", show_default=True, help="e.g. ch05,ch06")
@click.option("--learner-id", "learner_field", type=click.Choice(["email", "sid", "id", "name"]), default="email",
              show_default=True, help="Which field of the submitter in Gradescope's submission metadata is the "
                                      "learner id (their quiz numbers).")
@click.option("--time-budget", type=click.FloatRange(min=1), default=60, show_default=True,
              help="Seconds for one learner's code, all chapters together.")
@click.option("--sandbox", type=click.Choice(["barrier", "required", "off"]), default="barrier", show_default=True,
              help="barrier: bubblewrap where it starts on Gradescope's image, else learner code as an unprivileged "
                   "user that cannot read the references (the autograder runs as root), else nothing is graded; "
                   "required: grade nothing without bubblewrap; off: grade without a barrier (learner code can read "
                   "the references and the course seed).")
@click.option("--force", is_flag=True, help="Replace OUT if it exists.")
def gradescope_command(out: str, course_file: str | None, chapter_list: str, learner_field: str,
                       time_budget: float, sandbox: str, force: bool) -> None:
    """Build a Gradescope autograder zip (setup.sh, run_autograder, the instructor's grader, the course
    config) that grades every submission at the course seed, hidden checks included, into Gradescope's
    results.json. It holds the references and keys: upload it to Gradescope, never hand it out."""
    from pathlib import Path

    from grader.course import gradescope

    picked = chapters_option(chapter_list)
    the_course = instructor_course(course_file, "grade gradescope")
    try:
        built, settings = gradescope.build(Path(out), the_course, chapters=[c.id for c in picked],
                                           learner_field=learner_field, time_budget=time_budget, sandbox=sandbox,
                                           force=force)
    except gradescope.GradescopeError as exc:
        raise click.ClickException(str(exc)) from None
    click.echo(gradescope.describe(built, settings))


@click.command("regrade")
@click.argument("out", type=click.Path(exists=True, file_okay=False))
@click.option("--apply", "apply_it", is_flag=True,
              help="Record the new grades as a run of OUT/gradebook.db with --reason, and rewrite the moved learners' "
                   "reports and every class output (without it nothing but OUT/regrade.csv is written).")
@click.option("--reason", default=None, help="Why the grades change (required with --apply; changes.csv shows it).")
@click.option("--course", "course_file", type=click.Path(exists=True, dir_okay=False), default=None,
              help="Grade with this course file instead of the one the last run read (the differences are listed).")
@click.option("--overrides", "overrides_file", type=click.Path(dir_okay=False), default=None,
              help="Grade with this overrides file instead of the rows the last run read (the differences are listed).")
@click.option("--jobs", type=click.IntRange(min=1), default=None, help="Parallel workers (default: all cores).")
@click.option("--time-budget", type=click.FloatRange(min=1), default=None,
              help="Seconds for one learner's code, all chapters together (default: the last run's).")
@click.option("--no-sandbox", is_flag=True, help="Run learner code without bubblewrap even where it is installed.")
def regrade_command(out: str, apply_it: bool, reason: str | None, course_file: str | None,
                    overrides_file: str | None, jobs: int | None, time_budget: float | None, no_sandbox: bool) -> None:
    """Grade the submissions stored in OUT (grade batch's output folder) again with today's grader, with what the
    last run graded with (its course file, overrides, seed and chapters, as the history keeps them) unless
    --course or --overrides names others, and show whose grade would change and why, check by check, in
    OUT/regrade.csv (learner, old_score, new_score, checks_changed, why). Nothing else changes until --apply
    records it in the history as a run with its --reason."""
    from pathlib import Path

    from grader.course import regrade
    from grader.course.overrides import OverridesError
    from grader.course.workers import InfrastructureError
    from grader.safe_text import for_terminal

    if apply_it and not (reason or "").strip():
        raise click.UsageError("--apply records the regrade with its reason: give --reason TEXT (changes.csv and "
                               "every moved learner's history show it)")
    the_course = instructor_course(course_file, "grade regrade") if course_file else None
    if course_file is None:
        instructor_side("grade regrade")
    folder = Path(out)
    try:
        found = regrade.regrade(folder, the_course, overrides=Path(overrides_file) if overrides_file else None,
                                jobs=jobs, sandboxed=not no_sandbox, time_budget=time_budget)
    except regrade.RegradeError as exc:
        raise click.BadParameter(for_terminal(str(exc), one_line=True), param_hint="OUT") from None
    except OverridesError as exc:
        raise click.BadParameter(for_terminal(str(exc)), param_hint="--overrides") from None
    except InfrastructureError as exc:
        from grader.boundary import how_to_get_a_barrier

        click.echo(f"grade regrade: no learner was graded again: learner code cannot run here behind a barrier. "
                   f"{for_terminal(str(exc), one_line=True)}\nTo grade: {how_to_get_a_barrier()}.", err=True)
        sys.exit(EXIT_USAGE)
    written = regrade.write_csv(folder, found)
    info = found.run_info
    click.echo(f"Graded {plural(len(found.compared), 'learner')} of run {found.run} again (seed {found.settings.seed}, "
               f"{', '.join(found.settings.chapters)}) with grader {found.grader} (the run's: {info['grader']}).")
    if found.differences:
        click.echo(f"With what differs from run {found.run}, as named:")
        for difference in found.differences:
            click.echo(f"  {for_terminal(difference, one_line=True)}")
    else:
        click.echo(f"With what run {found.run} graded with (its course file, overrides, seed and chapters).")
    moved = found.moved
    if moved:
        click.echo(f"{len(moved)} learner's grade would change:" if len(moved) == 1 else
                   f"{len(moved)} learners' grades would change:")
        for change in moved:
            new = "not graded" if change.new_score is None else f"{change.new_score:g}"
            old = "none" if change.old_score is None else f"{change.old_score:g}"
            click.echo(f"  {for_terminal(change.learner, one_line=True)}: {old} -> {new}: "
                       f"{for_terminal(change.why, one_line=True)}")
    else:
        click.echo("No learner's grade, check verdict or adjustment would change.")
    for learner, why in sorted(found.left_out.items()):
        click.echo(f"  not graded again: {for_terminal(learner, one_line=True)}: {why}", err=True)
    for problem in found.override_problems + found.notes:
        click.echo(f"  {for_terminal(problem, one_line=True)}", err=True)
    click.echo(f"Written: {written}")
    if apply_it:
        run, notes = regrade.apply(folder, found, reason.strip())
        for note in notes:
            click.echo(f"  {for_terminal(note, one_line=True)}", err=True)
        click.echo(f"Recorded as run {run} of {folder / 'gradebook.db'} "
                   f"({for_terminal(reason.strip(), one_line=True)});"
                   " every class output is rebuilt from it (gradebook.csv and the LMS gradebooks, changes.csv, "
                   "junit.xml, the summary), and the moved learners' reports are written again.")
    elif moved:
        click.echo("Nothing else changed: `grade regrade OUT --apply --reason TEXT` records it.")


@click.command("selftest")
@click.option("--seeds", "count", type=click.IntRange(min=1), default=None,
              help="How many seeds: the public one, the course's, then 1, 2, 3 ... [default: 25]")
@click.option("--seed", "only", type=int, default=None,
              help="Check this one seed (with the public one to compare with), as a failure's command does.")
@click.option("--chapters", "chapter_list", default="all", show_default=True, help="e.g. ch05,ch06")
@click.option("--course", "course_file", type=click.Path(exists=True, dir_okay=False), default=None,
              help="The course configuration (default: solutions/course.yaml beside the references).")
@click.option("--quizzes", "quiz_dir", type=click.Path(exists=True, file_okay=False), default=None,
              help="Question banks and their keys to check, laid out as quizzes/ is (default: the grader's own).")
@click.option("--no-code", is_flag=True, help="Check the quiz only (no reference code runs).")
@click.option("--generated", is_flag=True, help="Also weigh the slips generated from the references (grader.judging.mutants; "
              "about four times the time): those told apart at some seeds only are listed as notes.")
@click.option("--no-sandbox", is_flag=True, help="Run the reference code without bubblewrap even where it is installed.")
def selftest_command(count: int | None, only: int | None, chapter_list: str, course_file: str | None,
                     quiz_dir: str | None, no_code: bool, generated: bool, no_sandbox: bool) -> None:
    """Check the course at many seeds, not only the public one, before learners meet it (and in CI): the
    reference solutions get every check's points at every seed; every mistake a check can name is told apart
    from the right value at the check's inputs at every seed (not only at most); every parametrised quiz
    question's key is finite, well-conditioned and told apart from its known wrong answers for every learner
    draw (learner id selftest-<seed>); the reference answers get full marks. Exits 1 naming each failing check
    or question at its first failing seed, with a command that reproduces it; 0 when everything holds."""
    import time
    from pathlib import Path

    from grader.course import selftest
    from grader.safe_text import for_terminal

    picked = [c.id for c in chapters_option(chapter_list)]
    the_course = instructor_course(course_file, "grade selftest")
    if only is not None and count is not None:
        raise click.UsageError("--seed checks one seed, --seeds many: give one of them")
    seeds = selftest.seeds_for(count or selftest.DEFAULT_SEEDS, the_course) if only is None else \
        list(dict.fromkeys([only, selftest.seeds_for(1)[0]]))
    extra = "".join(f" {option} {value}" for option, value in (("--course", course_file), ("--quizzes", quiz_dir))
                    if value)

    def command(item: str, seed: int) -> str:
        chapter = item.split("/", 1)[0]
        text = f"grade selftest --seed {seed} --chapters {chapter}{extra}"
        if "/quiz_" in item:
            text += f"; its numbers: grade quiz {chapter} --show --learner {selftest.LEARNER_PREFIX}{seed}"
        return text

    started = time.monotonic()
    shown = ", ".join(map(str, seeds[:4])) + (" ..." if len(seeds) > 4 else "")
    click.echo(f"grade selftest: {', '.join(picked) if len(picked) < 10 else 'every chapter'} at "
               f"{plural(len(seeds), 'seed')} ({shown})", err=True)
    outcome = selftest.run(picked, seeds, the_course, quiz_dir=Path(quiz_dir) if quiz_dir else None,
                           sandbox="off" if no_sandbox else "auto", code=not no_code, command=command,
                           report=None if only is None else {only}, generated=generated)
    for failure in outcome.failures:
        more = f" (and {plural(failure.other_seeds, 'other seed')})" if failure.other_seeds else ""
        click.echo(f"FAIL {failure.item} at seed {failure.seed}{more}:")
        for problem in failure.problems:
            click.echo(f"  {for_terminal(problem, one_line=True)}")
        click.echo(f"  reproduce: {for_terminal(failure.reproduce, one_line=True)}")
    for note in outcome.notes:
        click.echo(f"note: {for_terminal(note, one_line=True)}")
    counted = ", ".join(f"{n} {what}" for what, n in outcome.counted.items())
    verdict = (f"{plural(len(outcome.failures), 'check or question', 'checks or questions')} fail"
               if outcome.failures else "everything holds")
    click.echo(f"{verdict} at {plural(len(seeds), 'seed')} ({counted}; {time.monotonic() - started:.1f} s).")
    sys.exit(EXIT_NOT_ALL_PASSED if outcome.failures else EXIT_ALL_PASSED)


@click.command("review")
@click.argument("out", type=click.Path(exists=True, file_okay=False))
@click.option("--port", type=click.IntRange(min=0, max=65535), default=0,
              help="The port on 127.0.0.1 (default: a free one the system gives).")
@click.option("--read-only", is_flag=True, help="Show everything, record nothing (for a TA).")
@click.option("--who", default="the instructor", show_default=True,
              help="Who records the overrides made on the page (each can be changed in its form).")
@click.option("--no-browser", is_flag=True, help="Print the address only; do not open a browser.")
def review_command(out: str, port: int, read_only: bool, who: str, no_browser: bool) -> None:
    """Review a batch's output folder OUT in the browser: every learner with their total, chapters, late penalty,
    overrides, similar submissions and named mistakes (filter and sort); a learner's code beside each failing check;
    an override or a late waiver recorded with its reason through the history, every class output rebuilt at once.
    Served on 127.0.0.1 only, behind a secret token in the address it prints. Needs the review extra:
    pip install "jacobians-grader[review]"."""
    from pathlib import Path

    from grader.course.review import ReviewError
    from grader.safe_text import for_terminal

    instructor_side("grade review")
    try:
        from grader.faces import review_server
        import starlette  # noqa: F401
        import uvicorn  # noqa: F401
    except ImportError:
        raise click.ClickException('grade review needs Starlette and uvicorn: pip install "jacobians-grader[review]"') \
            from None
    try:
        review_server.serve(Path(out), port=port, read_only=read_only, who=who, open_browser=not no_browser,
                            announce=lambda line: click.echo(for_terminal(line, one_line=True)))
    except ReviewError as exc:
        raise click.BadParameter(for_terminal(str(exc), one_line=True), param_hint="OUT") from None
    except OSError as exc:
        raise click.ClickException(f"cannot listen on 127.0.0.1:{port}: {exc}") from None
