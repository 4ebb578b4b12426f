"""`grade gradescope OUT.zip`: a Gradescope autograder that grades submissions officially, and its run.

The zip follows Gradescope's autograder layout (https://gradescope-autograders.readthedocs.io/en/latest/specs/):
at its root `setup.sh` (run once, as root, when Gradescope builds the image: installs bubblewrap and
Python's venv where missing, then the grader into /autograder/source/venv) and `run_autograder`
(copied to /autograder/run_autograder, run for every submission), beside the instructor's grader as a
wheel (references, oracle and quiz keys included: this zip is for Gradescope only, never for learners),
the course config (its secret course seed and hidden checks) and `autograder.json` (the settings this
module reads back).

Each run (`python -m grader.course.gradescope run /autograder`) grades /autograder/submission exactly as
`grade batch` grades one learner: staged the same way, hidden checks included, at a seed of the submission's own
drawn from the course seed (submission_seed), in bubblewrap where it starts (else, with --sandbox barrier, as an
unprivileged user; the output says which), and always
writes /autograder/results/results.json: a submission without chapter files gets score 0 and the reason;
a failure outside the learner's code gets score 0 with "NOT GRADED", the reason, and a non-zero exit so
the instructor sees the run failed. The learner id (their quiz numbers) comes from
/autograder/submission_metadata.json (the field chosen at build time, email by default); a learner.yaml
in the submission naming someone else, quiz answers that fit another id's numbers and what the archive's
manifest (`grade submit`) says to look at (another handout, edited after packing) are flagged in the output.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import stat
import sys
import tempfile
import time
import zipfile
from dataclasses import asdict, dataclass, field
from datetime import datetime
from pathlib import Path

SETTINGS_FILE = "autograder.json"
TRY_TIME = "2026-05-01T12:00:00+00:00"  # the submission time README.txt's try gives where the course has no deadline
COURSE_FILE = "course.yaml"
LEARNER_FIELDS = ("email", "sid", "id", "name")
SANDBOX_MODES = ("barrier", "required", "off")  # grader.boundary.SandboxMode: never a silent "auto" here
PROJECT = Path(__file__).resolve().parents[2]


class GradescopeError(RuntimeError):
    """The autograder cannot be built (the message says why)."""


@dataclass
class Settings:
    """What the autograder zip's autograder.json holds: how every run grades."""

    course: str
    chapters: list[str]
    learner_field: str = "email"
    time_budget: float = 60.0
    sandbox: str = "barrier"  # "barrier": bubblewrap, else a dropped uid, else not graded; "required": bubblewrap; "off"
    grader: str = ""  # the wheel's file name
    hidden: list[str] = field(default_factory=list)  # for the instructor's eyes; the run reads course.yaml

    @classmethod
    def read(cls, path: Path) -> Settings:
        data = json.loads(path.read_text(encoding="utf-8"))
        return cls(**{k: v for k, v in data.items() if k in cls.__dataclass_fields__})


SETUP_SH = r"""#!/usr/bin/env bash
# Gradescope runs this once, as root, when it builds the autograder's image. It installs what is missing
# (Python's venv, bubblewrap for the sandbox), then the course's grader into source/venv, and says
# whether learner code can run in the sandbox on this image.
set -euo pipefail
SOURCE="$(cd "$(dirname "$0")" && pwd)"
need=()
command -v python3 >/dev/null 2>&1 || need+=(python3)
python3 -c "import ensurepip, venv" >/dev/null 2>&1 || need+=(python3-venv)
command -v bwrap >/dev/null 2>&1 || need+=(bubblewrap)
command -v setpriv >/dev/null 2>&1 || need+=(util-linux)
if [ "${#need[@]}" -gt 0 ]; then
    if command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
        export DEBIAN_FRONTEND=noninteractive
        apt-get update -q && apt-get install -y -q --no-install-recommends "${need[@]}" \
            || echo "setup.sh: could not install ${need[*]}" >&2
    else
        echo "setup.sh: missing ${need[*]} and no apt-get as root to install them" >&2
    fi
fi
python3 -c "import sys; sys.exit(0 if sys.version_info >= (3, 10) else 'setup.sh: the grader needs Python 3.10 or later, this image has ' + sys.version.split()[0])"
# where bubblewrap cannot start, learner code runs as this unprivileged user, which cannot read the answers
if [ "$(id -u)" = 0 ] && ! id grader-learner >/dev/null 2>&1; then
    useradd --system --no-create-home --shell /usr/sbin/nologin grader-learner 2>/dev/null \
        || echo "setup.sh: could not create the user grader-learner; without it nothing is graded where bubblewrap cannot start" >&2
fi
python3 -m venv "$SOURCE/venv"
"$SOURCE/venv/bin/python" -m pip install --quiet --disable-pip-version-check "$SOURCE/{wheel}"
"$SOURCE/venv/bin/python" -m grader.course.gradescope check "$(dirname "$SOURCE")"
"""

RUN_AUTOGRADER = r"""#!/usr/bin/env bash
# Gradescope runs this for every submission: it grades submission/ into results/results.json (always
# written) with the course's grader, at a seed of the submission's own drawn from the course seed, hidden
# checks included; the learner id comes from submission_metadata.json.
ROOT="$(cd "$(dirname "$0")" && pwd)"
PYTHON="$ROOT/source/venv/bin/python"
if [ ! -x "$PYTHON" ]; then
    mkdir -p "$ROOT/results"
    printf '%s\n' '{"score": 0, "output": "NOT GRADED: the autograder is not installed (setup.sh failed when the image was built). This is not your grade: your instructor will fix it and grade again.", "tests": [], "stdout_visibility": "hidden", "extra_data": {"not_graded": "setup.sh failed"}}' > "$ROOT/results/results.json"
    echo "run_autograder: $PYTHON is missing: setup.sh failed; see the image build's log" >&2
    exit 1
fi
exec "$PYTHON" -m grader.course.gradescope run "$ROOT"
"""

README = """The Gradescope autograder of the course {course}, built by `grade gradescope` ({grader}).

Upload this zip as the autograder of a Gradescope programming assignment (Configure Autograder,
Zip file upload). It holds the instructor's grader with the reference solutions and quiz keys, and the
course config with its secret seed: never give it to learners.

Each submission is graded at a seed of its own, drawn from the course seed, the learner and
Gradescope's submission id (a regrade of the same submission draws the same), hidden checks included
(shown to the learner after grades are published), chapters {chapters}, {budget:g} s for a learner's
code; the learner id (their quiz numbers and option letters) is the submitter's `{field}` in
Gradescope's submission metadata. Learners submit their chapter files (exercises/chNN_*.py, or the
files at the top of the upload) and quiz answers (answers/chNN.yaml).

Sandbox: {sandbox}. Try it on your machine as root (Linux with python3 and unzip; bubblewrap, or the
user grader-learner that setup.sh creates), in bash, beside {zipname}: set AG to a new folder (it
stands for Gradescope's /autograder) and SUB to a submission folder, then run the lines below. They
write submission_metadata.json as Gradescope does (its documented fields: the submitter in `users`,
the submission's `id` and time `created_at`, the assignment's `due_date`); without it nothing is
graded, as on Gradescope.
  AG=/tmp/ag; SUB=path/to/a/submission
  mkdir -p "$AG/source" && unzip -o -q "{zipname}" -d "$AG/source" && bash "$AG/source/setup.sh"
  cp "$AG/source/run_autograder" "$AG/" && rm -rf "$AG/submission" && cp -r "$SUB" "$AG/submission"
  printf '%s\\n' '{{"id": 1, "created_at": "{when}", "submission_method": "upload",
    "assignment": {{"title": "Try", "due_date": "{when}", "late_due_date": null}},
    "users": [{{"email": "learner@example.edu", "name": "A Learner", "sid": "s1", "id": 1}}],
    "previous_submissions": []}}' > "$AG/submission_metadata.json"
  "$AG/run_autograder"; cat "$AG/results/results.json"
It grades SUB as that user (by their {field}), submitted on time.
"""


# ------------------------------------------------------------------------------------ build

def _project_root() -> Path:
    if not (PROJECT / "pyproject.toml").is_file() or not (PROJECT / "solutions").is_dir():
        raise GradescopeError(f"no project checkout around the grader ({PROJECT} has no pyproject.toml and "
                              "solutions/): run `grade gradescope` in the lesson's project, which has the references")
    return PROJECT


def _copy_of(project: Path, folder: Path) -> Path:
    """What the instructor's wheel is built from, copied into `folder`: a build writes into the tree it builds
    (build/, *.egg-info), so two builds of one project at once must not share it."""
    import shutil

    skip = shutil.ignore_patterns("__pycache__", "*.pyc", "build", "*.egg-info", ".venv", ".git")
    folder.mkdir(parents=True)
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(project / name, folder / name)
    for name in ("grader", "solutions", "quizzes"):
        shutil.copytree(project / name, folder / name, ignore=skip)
    return folder


def build(out: Path, course, *, chapters: list[str], learner_field: str = "email", time_budget: float = 60.0,
          sandbox: str = "barrier", force: bool = False) -> tuple[Path, Settings]:
    """Write the autograder zip to `out` (refused if it exists, unless `force`)."""
    from grader.course.release import ReleaseError, _build_wheel

    if out.exists() and not force:
        raise GradescopeError(f"{out} exists; choose another name (or --force to replace it)")
    if course.seed is None:
        raise GradescopeError(f"{course.source}: the course has no seed; a Gradescope autograder grades at the course "
                              "seed (a submission hard-coding the public values would pass at the public one): set "
                              "`seed:` in the course config")
    if not course.source or not Path(course.source).is_file():
        raise GradescopeError("no course config file to ship (solutions/course.yaml or --course FILE)")
    project = _project_root()
    with tempfile.TemporaryDirectory(prefix="gradescope-") as temporary:
        try:
            wheel = _build_wheel(_copy_of(project, Path(temporary) / "project"), Path(temporary))
        except ReleaseError as exc:
            raise GradescopeError(str(exc)) from None
        settings = Settings(course=course.id, chapters=list(chapters), learner_field=learner_field,
                            time_budget=float(time_budget), sandbox=sandbox, grader=wheel.name,
                            hidden=sorted(course.hidden))
        described = {"barrier": "bubblewrap where it starts on Gradescope's image, else learner code as an "
                                "unprivileged user that cannot read the references, keys or course file, else nothing "
                                "is graded",
                     "required": "required: where bubblewrap does not start, nothing is graded",
                     "off": "off: learner code runs without a barrier and can read the references and the course "
                            "seed"}[sandbox]
        out.parent.mkdir(parents=True, exist_ok=True)
        partial = out.with_name(f".{out.name}.{os.getpid()}.tmp")
        with zipfile.ZipFile(partial, "w", compression=zipfile.ZIP_DEFLATED) as archive:
            def add(name: str, text: str | bytes, mode: int = 0o644) -> None:
                info = zipfile.ZipInfo(name, date_time=(2026, 1, 1, 0, 0, 0))
                info.external_attr = (0o100000 | mode) << 16
                info.compress_type = zipfile.ZIP_DEFLATED
                archive.writestr(info, text)

            add("setup.sh", SETUP_SH.replace("{wheel}", wheel.name), 0o755)
            add("run_autograder", RUN_AUTOGRADER, 0o755)
            add(wheel.name, wheel.read_bytes())
            add(COURSE_FILE, Path(course.source).read_bytes())
            add(SETTINGS_FILE, json.dumps(asdict(settings), indent=1) + "\n")
            when = course.late.deadline.isoformat() if course.late else TRY_TIME  # on time: no late penalty
            add("README.txt", README.format(course=course.id, grader=wheel.name, chapters=", ".join(chapters),
                                            budget=time_budget, field=learner_field, sandbox=described,
                                            zipname=out.name, when=when))
        os.replace(partial, out)
    return out, settings


def describe(out: Path, settings: Settings) -> str:
    return (f"Gradescope autograder in {out} ({out.stat().st_size / 1024:.0f} KiB): setup.sh, run_autograder, "
            f"{settings.grader}, {COURSE_FILE} and {SETTINGS_FILE}; chapters {', '.join(settings.chapters)}; learner id: "
            f"the submitter's {settings.learner_field}; sandbox {settings.sandbox}. It holds the references, the "
            "keys and the course seed: upload it to Gradescope, never hand it out.")


# ------------------------------------------------------------------------------------ run

@dataclass
class Metadata:
    """What Gradescope's submission_metadata.json says of this submission, as far as it is usable: the learner
    id (the field chosen at build time), the submission's id, its time and due dates (Gradescope's, which the
    learner cannot write: they decide the late penalty)."""

    learner: str | None  # None: unusable, and `source` says why
    source: str  # where the id came from, or why there is none
    submission_id: str | None = None
    created: datetime | None = None  # when it was submitted
    due: datetime | None = None  # the assignment's due date in Gradescope
    own_due: datetime | None = None  # the submitter's own due date where Gradescope lists one (an extension)

    @classmethod
    def read(cls, root: Path, learner_field: str) -> Metadata:
        from grader.core.policy import parse_time
        from grader.ids import id_problem

        path = root / "submission_metadata.json"
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            return cls(None, f"{path.name} cannot be read ({type(exc).__name__})")
        if not isinstance(data, dict):
            return cls(None, f"{path.name} is not Gradescope's submission metadata")

        def when(value: object) -> datetime | None:
            return parse_time(value) if isinstance(value, str) else None

        assignment = data.get("assignment") if isinstance(data.get("assignment"), dict) else {}
        users = data.get("users")
        first = users[0] if isinstance(users, list) and users and isinstance(users[0], dict) else {}
        own = first.get("assignment") if isinstance(first.get("assignment"), dict) else {}
        found = cls(None, "", str(data["id"]) if isinstance(data.get("id"), (int, str)) else None,
                    when(data.get("created_at")), when(assignment.get("due_date")), when(own.get("due_date")))
        value = first.get(learner_field)
        who = str(value).strip() if value is not None else ""
        if not first:
            found.source = f"{path.name} names no submitter"
        elif not who:
            found.source = f"{path.name}: the submitter has no {learner_field}"
        elif id_problem(who):
            found.source = f"{path.name}: the submitter's {learner_field} {id_problem(who)}"
        else:
            group = (f"; a group of {len(users)}: the quiz is graded with the first submitter's numbers"
                     if len(users) > 1 else "")
            found.learner, found.source = who, f"the submitter's {learner_field} in {path.name}{group}"
        return found

    def deadline(self, late) -> object:
        """The course's late penalty (grader.course_config.Late) with this submitter's extension: the course's deadline
        moved by as much as Gradescope moved the submitter's own due date past the assignment's."""
        if late is None or self.due is None or self.own_due is None or self.own_due <= self.due:
            return late
        return dataclasses.replace(late, deadline=late.deadline + (self.own_due - self.due))


def learner_from_metadata(root: Path, learner_field: str) -> tuple[str | None, str]:
    """(the learner id from submission_metadata.json, or None; a sentence saying where it came from or why not)."""
    metadata = Metadata.read(root, learner_field)
    return metadata.learner, metadata.source


def submission_seed(course_seed: int, learner: str, submission_id: str | None) -> int:
    """The seed one Gradescope submission is graded at: drawn from the course seed, the learner and the
    submission's id, so each attempt has inputs of its own (expected values a learner saw after one attempt
    say nothing of the next), and a regrade of the same submission draws the same ones."""
    if submission_id is None:
        return course_seed
    digest = hashlib.sha256(f"{course_seed}/{learner}/{submission_id}".encode("utf-8", "surrogatepass")).digest()
    return int.from_bytes(digest[:4], "big") & 0x7FFFFFFF


# What the learner's code must never read, in the Gradescope layout: the course file (its seed), the settings,
# the instructor's wheel, the references and the keys where the grader is installed, the submission's metadata
# (it holds the previous submission's results, hidden checks' outputs included).
def secrets(root: Path) -> list[Path]:
    from grader.boundary import answer_places

    return [root / "source" / COURSE_FILE, root / "source" / SETTINGS_FILE, root / "submission_metadata.json",
            *sorted((root / "source").glob("*.whl")), *map(Path, answer_places())]


def root_only(paths: list[Path], root: Path) -> None:
    """Make `paths` (files, or folders with all they hold) readable by root only (this process is root), those
    inside the autograder's folder `root` (a grader installed elsewhere is not the autograder's to change: the
    barrier's probe then finds its answers readable, and nothing is graded)."""
    for path in paths:
        if not path.exists() or not path.resolve().is_relative_to(root.resolve()):
            continue
        for place in [path] if not path.is_dir() else [path, *path.rglob("*")]:
            if not place.is_symlink():
                place.chmod(stat.S_IMODE(place.stat().st_mode) & ~0o077)


def _door(mode: str, hidden_paths: list[Path] = ()):
    """(the door to grade behind or None, the isolation line, why not): "barrier" grades behind bubblewrap or, as root
    where bubblewrap cannot start, as an unprivileged user that cannot read `hidden_paths`, and refuses to grade with
    neither; "required" only behind bubblewrap; "off" without a barrier, as the instructor chose."""
    from grader.boundary import BoundaryUnavailable
    from grader.core.transaction import Door

    door = Door(mode, probe=True, turned_off="by the autograder's settings (grade gradescope --sandbox off)",
                secrets=tuple(str(p) for p in hidden_paths))
    try:
        return door, door.isolation, ""
    except BoundaryUnavailable as exc:
        reason = " ".join(str(exc).split())[:600]
        fix = ("build the autograder with --sandbox barrier, to grade as an unprivileged user where bubblewrap does "
               "not start" if mode == "required" else "use an image where bubblewrap starts (user namespaces) and "
               "run the autograder as root, or, knowing that learner code can then read the references, build the "
               "autograder with --sandbox off")
        return None, f"isolation: no barrier stands here ({reason}); nothing is graded: {fix}", reason


def _stage(root: Path, learner: str, staging: Path) -> Path:
    """The submission staged as grade batch stages one (chapter and answer files only); an upload that is
    one .zip is read from inside it. StagingError when there is nothing to grade."""
    from grader.course.staging import Entry, StagingError, stage

    submission = root / "submission"
    if not submission.is_dir():
        raise StagingError("the submission folder is missing")
    try:
        return stage(Entry(learner, submission), staging)
    except StagingError:
        zips = [p for p in submission.iterdir() if p.suffix.lower() == ".zip" and p.is_file() and not p.is_symlink()]
        if len(zips) != 1:
            raise
        return stage(Entry(learner, zips[0]), staging)


def _write(results: Path, text: str) -> None:
    results.mkdir(parents=True, exist_ok=True)
    temporary = results / f".results.json.{os.getpid()}.tmp"
    temporary.write_text(text, encoding="utf-8")
    os.replace(temporary, results / "results.json")


def _not_graded(reason: str, started: float, heading: list[str], isolation: str) -> str:
    from grader.render import lms

    message = (f"NOT GRADED: the autograder could not grade this submission for a reason outside your code "
               f"({reason}). This is not your grade: your instructor sees this and will grade it again.")
    return lms.gradescope_not_graded(message, execution_time=time.monotonic() - started, heading=heading,
                                     isolation=isolation, not_graded=reason)


def run(root: Path) -> int:
    """Grade root/submission into root/results/results.json (always written). 0 when graded (whatever the
    score) or when the submission holds nothing to grade; 1 when it could not be graded for a reason outside
    the learner's code (the results say NOT GRADED, and why, for the instructor)."""
    from grader.safe_text import for_terminal

    started = time.monotonic()
    results = root / "results"
    heading: list[str] = []
    isolation = ""
    try:
        settings = Settings.read(root / "source" / SETTINGS_FILE)
        from grader.core.pipeline import instructor_course
        from grader.course.staging import StagingError
        from grader.render import lms

        course = instructor_course(str(root / "source" / COURSE_FILE))
        metadata = Metadata.read(root, settings.learner_field)
        hidden_paths = secrets(root)
        if hasattr(os, "geteuid") and os.geteuid() == 0:
            root_only(hidden_paths, root)  # before any learner code runs: readable by root only
        door, isolation, reason = _door(settings.sandbox, hidden_paths)
        print(isolation, flush=True)
        if door is None:
            _write(results, _not_graded(f"no barrier between learner code and the answers here: {reason}", started,
                                        heading, isolation))
            print(f"NOT GRADED: {for_terminal(isolation)}", flush=True)
            return 1
        if metadata.learner is None:  # never a silent fallback to an id the upload itself names
            _write(results, _not_graded(f"no usable learner id: {metadata.source} (the autograder takes the "
                                        f"submitter's {settings.learner_field}; rebuild it with --learner-id naming "
                                        "a field every learner has)", started, heading, isolation))
            print(f"NOT GRADED: no usable learner id: {for_terminal(metadata.source)}", flush=True)
            return 1
        learner = metadata.learner
        seed = submission_seed(course.grading_seed, learner, metadata.submission_id)
        with tempfile.TemporaryDirectory(prefix="gradescope-staging-") as staging:
            os.chmod(staging, 0o755)
            try:
                staged = _stage(root, learner, Path(staging))
            except StagingError as exc:
                message = (f"Your submission could not be graded: {exc}. Submit your chapter files (exercises/chNN_*.py,"
                           " or the files at the top of the upload) and your quiz answers (answers/chNN.yaml).")
                _write(results, lms.gradescope_not_graded(message, execution_time=time.monotonic() - started))
                print(for_terminal(message), flush=True)
                return 0
            attempt = ("at a seed of this submission's own, drawn from the course seed" if seed != course.grading_seed
                       else "at the course seed")
            heading = [f"Graded as {learner} ({metadata.source}), {attempt}."]
            from grader.boundary import Limits
            from grader.core.pipeline import Request
            from grader.core.policy import Policy
            from grader.core.transaction import grade_submission
            from grader.course import submit
            from grader.course.workers import learner_yaml_warnings
            from grader.submission import Submission

            manifest, packed = submit.check(staged / "exercises", learner, course.id, course.current_handout)
            warnings = learner_yaml_warnings(staged, learner, "Gradescope's submission metadata") + packed
            late = metadata.deadline(course.late)
            request = Request(tuple(settings.chapters), seed, learner=learner, label=learner,
                              learner_from=metadata.source,
                              other_ids=(str(manifest.get("learner")),) if manifest else ())
            try:
                graded = grade_submission(Submission(staged, "exercises"), request, door,
                                          Policy((), late, metadata.created),
                                          limits=Limits(learner_seconds=settings.time_budget), course=course)
            finally:
                door.close()
            report = graded.report
            warnings += report.flags
        if report.infrastructure:
            _write(results, _not_graded(report.infrastructure, started, heading, isolation))
            print(f"NOT GRADED: {for_terminal(report.infrastructure)}", flush=True)
            return 1
        warnings += _late_notes(course.late, late, metadata)
        _write(results, lms.gradescope(report, hidden=course.hidden, execution_time=time.monotonic() - started,
                                       heading=heading, notes=warnings, isolation=isolation,
                                       submission=metadata.submission_id))
        print(for_terminal(f"{heading[0]} Score {report.score:g}/{report.max_score:g}."), flush=True)
        for line in lms.summary_lines(report) + warnings:
            print(for_terminal(line), flush=True)
        if report.learner_output:
            print("What the learner's code printed (first 2000 characters):", flush=True)
            print(for_terminal(report.learner_output[:2000]), flush=True)
        return 0
    except Exception as exc:  # noqa: BLE001  the grader itself broke: never a silent zero, never no results
        import traceback

        traceback.print_exc()
        _write(results, _not_graded(f"the grader failed: {type(exc).__name__}: {exc}", started, heading, isolation))
        return 1


def _late_notes(course_late, late, metadata: Metadata) -> list[str]:
    """What the output says of the late penalty: the extension applied, or why no penalty could be."""
    if course_late is None:
        return []
    if metadata.created is None:
        return ["No late penalty applied: Gradescope's metadata gives no submission time (created_at)."]
    if late is not course_late:
        return [f"Deadline {late.deadline.isoformat()} for this submitter: the course's, moved by the extension "
                "Gradescope lists for them."]
    return []


def check(root: Path) -> int:
    """At image build time: say whether learner code can run in the sandbox here (never fails the build)."""
    try:
        settings = Settings.read(root / "source" / SETTINGS_FILE)
    except (OSError, ValueError, TypeError) as exc:
        print(f"grader.course.gradescope check: {SETTINGS_FILE} cannot be read: {exc}", file=sys.stderr)
        return 1
    hidden_paths = secrets(root)
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        root_only(hidden_paths, root)
    door, isolation, _ = _door(settings.sandbox, hidden_paths)
    print(isolation)
    if door is not None:
        door.close()
    else:
        print("WARNING: no barrier between learner code and the answers stands on this image: no submission will be "
              "graded (every run says NOT GRADED, and why).")
    return 0


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 2 or args[0] not in ("run", "check"):
        print("usage: python -m grader.course.gradescope run|check AUTOGRADER_ROOT   (Gradescope's is /autograder)",
              file=sys.stderr)
        return 2
    root = Path(args[1]).resolve()
    return run(root) if args[0] == "run" else check(root)


if __name__ == "__main__":
    code = main()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)  # everything is written; skip the slow teardown of numpy & co
