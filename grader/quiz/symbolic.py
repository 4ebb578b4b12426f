"""Answers as expressions, read without eval of raw input.

Every answer is first parsed by Python's `ast` (after `^` -> `**`) and checked against a
whitelist of the syntax tree: numbers, the question's symbols, `pi` and `e`, + - * / ** and unary
signs, and calls with plain arguments to a fixed set of functions. Length is capped, and so are
exponents: a power's exponent is a number of size at most MAX_EXPONENT (`x^2`, `r^-2`,
`(x^2+y^2)^(1/2)`), except for a power of `e`; powers of powers are refused. Nothing else reaches
sympy or the evaluator below.

Equivalence of two expressions: both are evaluated with plain floats (math module, no sympy) at
random points of the question's domain. Agreement at NUMERIC_POINTS points (at least
MIN_POINTS) means equal; a clear difference at one point where both sides are defined means not
equal (then simplify(a - b) cannot be 0 either). Only when too few points are defined does sympy
decide: parse_expr with exactly the allowed names, and simplify(a - b) == 0 within
SIMPLIFY_SECONDS, in a separate process that is killed when the time is up (Simplifier).
"Undecided" (a timeout, sympy's error) is never "equal". So sympy is imported only for those rare
answers, never in the grading process itself, and `grade` stays fast.
"""

from __future__ import annotations

import ast
import json
import math
import os
import random
import selectors
import signal
import subprocess
import sys
import time
from fractions import Fraction

MAX_LENGTH = 200
MAX_EXPONENT = 10
SIMPLIFY_SECONDS = 2.0
NUMERIC_POINTS = 12
MIN_POINTS = 8
RELATIVE_TOLERANCE = 1e-8
DEFAULT_DOMAIN = (0.5, 3.0)  # each symbol in +-[0.5, 3] unless the question gives its own range

# name -> (float implementation, accepted numbers of arguments)
FUNCTIONS: dict[str, tuple] = {
    "sqrt": (math.sqrt, (1,)), "sin": (math.sin, (1,)), "cos": (math.cos, (1,)), "tan": (math.tan, (1,)),
    "atan": (math.atan, (1,)), "atan2": (math.atan2, (2,)), "exp": (math.exp, (1,)),
    "log": (math.log, (1, 2)), "Abs": (abs, (1,)), "abs": (abs, (1,)),
}
CONSTANTS = {"pi": math.pi, "e": math.e}


class AnswerError(ValueError):
    """An answer that cannot be read; the message says why, in the learner's terms."""


class Undefined(ArithmeticError):
    """The expression has no real value at this point (outside its domain, overflow)."""


def _constant(node: ast.AST) -> Fraction | None:
    """The exact value of a number-only expression (+ - * / and signs), None if it has names or calls."""
    if isinstance(node, ast.Constant) and type(node.value) in (int, float):
        try:
            return Fraction(node.value)
        except (OverflowError, ValueError):  # inf, nan
            raise AnswerError("numbers must be finite") from None
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        value = _constant(node.operand)
        return None if value is None else (-value if isinstance(node.op, ast.USub) else value)
    if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Add, ast.Sub, ast.Mult, ast.Div)):
        left, right = _constant(node.left), _constant(node.right)
        if left is None or right is None:
            return None
        if isinstance(node.op, ast.Add):
            return left + right
        if isinstance(node.op, ast.Sub):
            return left - right
        if isinstance(node.op, ast.Mult):
            return left * right
        if right == 0:
            raise AnswerError("division by zero")
        return left / right
    return None


def _has_power(node: ast.AST) -> bool:
    return any(isinstance(n, ast.BinOp) and isinstance(n.op, ast.Pow) for n in ast.walk(node))


def _check_power(node: ast.BinOp, symbols: tuple[str, ...]) -> None:
    if isinstance(node.left, ast.BinOp) and isinstance(node.left.op, ast.Pow):
        raise AnswerError("a power of a power is not allowed; write it out with brackets and one ^")
    if isinstance(node.left, ast.Name) and node.left.id == "e" and "e" not in symbols:
        return  # e^(anything allowed): stays exp(...) in sympy, overflows harmlessly as a float
    if _has_power(node.right):
        raise AnswerError("a power of a power is not allowed; write it out with brackets and one ^")
    exponent = _constant(node.right)
    if exponent is None:
        raise AnswerError("an exponent must be a number such as 2, -1 or 1/2 (write exp(x) or e^x "
                          "for a power of e)")
    if abs(exponent) > MAX_EXPONENT:
        raise AnswerError(f"exponents above {MAX_EXPONENT} in size are not allowed")


def _check_tree(tree: ast.AST, symbols: tuple[str, ...], lists: bool) -> None:
    allowed_names = set(symbols) | set(CONSTANTS)
    for node in ast.walk(tree):
        if lists and isinstance(node, (ast.List, ast.Tuple)):
            continue
        if isinstance(node, (ast.Expression, ast.Load)):
            continue
        if isinstance(node, ast.operator):
            if not isinstance(node, (ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow)):
                raise AnswerError(f"the operator {type(node).__name__} is not allowed (use + - * / ^)")
            continue
        if isinstance(node, ast.unaryop):
            if not isinstance(node, (ast.USub, ast.UAdd)):
                raise AnswerError("only a leading minus or plus sign is allowed")
            continue
        if isinstance(node, ast.BinOp):
            if isinstance(node.op, ast.Pow):
                _check_power(node, symbols)
            continue
        if isinstance(node, ast.UnaryOp):
            continue
        if isinstance(node, ast.Constant):
            if type(node.value) not in (int, float):
                raise AnswerError("only numbers and the question's symbols are allowed (no strings)")
            if not math.isfinite(node.value):
                raise AnswerError("numbers must be finite")
            continue
        if isinstance(node, ast.Name):
            if node.id not in allowed_names and node.id not in FUNCTIONS:
                allowed = ", ".join(symbols) or "none"
                raise AnswerError(f"unknown name {node.id!r} (symbols allowed here: {allowed})")
            continue
        if isinstance(node, ast.Call):
            if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS:
                raise AnswerError(f"only these functions may be called: {', '.join(FUNCTIONS)}")
            if node.keywords:
                raise AnswerError("function calls take plain arguments only")
            arities = FUNCTIONS[node.func.id][1]
            if len(node.args) not in arities:
                wanted = " or ".join(map(str, arities))
                raise AnswerError(f"{node.func.id} takes {wanted} argument(s), got {len(node.args)}")
            continue
        raise AnswerError(f"{type(node).__name__} is not allowed in an answer")
    called = {id(node.func) for node in ast.walk(tree) if isinstance(node, ast.Call)}
    for node in ast.walk(tree):  # a bare function name used as a value, e.g. "sqrt + 1"
        if isinstance(node, ast.Name) and node.id in FUNCTIONS and id(node) not in called \
                and node.id not in allowed_names:
            raise AnswerError(f"{node.id} is a function: write {node.id}(...)")


def check_text(text: object, symbols: tuple[str, ...] = (), lists: bool = False) -> ast.Expression:
    """Whitelist-check an answer's syntax tree (with `lists`, brackets of numbers too); the tree,
    or AnswerError. Needs neither sympy nor any evaluation."""
    if not isinstance(text, str):
        text = str(text)
    if len(text) > MAX_LENGTH:
        raise AnswerError(f"the answer is {len(text)} characters long; at most {MAX_LENGTH} are read")
    if not text.isascii():
        bad = next(ch for ch in text if not ch.isascii())
        raise AnswerError(f"the character {bad!r} (U+{ord(bad):04X}) is not plain ASCII; type it with the keyboard "
                          "(e.g. - for a minus sign, x for the letter x, sqrt(...) for a root)")
    if not text.strip():
        raise AnswerError("the answer is empty")
    try:
        tree = ast.parse(text.replace("^", "**").strip(), mode="eval")
    except SyntaxError as exc:
        raise AnswerError(f"cannot read it as a formula ({exc.msg})") from None
    except (ValueError, RecursionError, MemoryError):  # e.g. a NUL byte, absurd nesting
        raise AnswerError("cannot read it as a formula") from None
    _check_tree(tree, symbols, lists)
    return tree


def evaluate(node: ast.AST, values: dict[str, float]) -> float:
    """A checked tree's value as a float at `values` (symbol -> number); Undefined where it has none."""
    if isinstance(node, ast.Expression):
        return evaluate(node.body, values)
    if isinstance(node, ast.Constant):
        return float(node.value)
    if isinstance(node, ast.Name):
        if node.id in values:
            return values[node.id]
        return CONSTANTS[node.id]
    try:
        if isinstance(node, ast.UnaryOp):
            operand = evaluate(node.operand, values)
            result = -operand if isinstance(node.op, ast.USub) else operand
        elif isinstance(node, ast.BinOp):
            left, right = evaluate(node.left, values), evaluate(node.right, values)
            if isinstance(node.op, ast.Add):
                result = left + right
            elif isinstance(node.op, ast.Sub):
                result = left - right
            elif isinstance(node.op, ast.Mult):
                result = left * right
            elif isinstance(node.op, ast.Div):
                result = left / right
            else:
                result = left ** right
        elif isinstance(node, ast.Call):
            function = FUNCTIONS[node.func.id][0]
            result = function(*[evaluate(arg, values) for arg in node.args])
        else:
            raise AnswerError(f"{type(node).__name__} has no value")
    except ZeroDivisionError:
        raise Undefined("division by zero") from None
    except OverflowError:
        raise Undefined("too large") from None
    except ValueError:
        raise Undefined("outside a function's domain, e.g. sqrt or log of a negative number") from None
    if isinstance(result, complex) or not math.isfinite(result):
        raise Undefined("not a finite real number")
    return float(result)


def number(text: object) -> float:
    """A numeric answer: 0.6, '0.6', '3/5', '-1e-5', 'sqrt(3)/2', '2*pi'; AnswerError otherwise."""
    if isinstance(text, bool) or text is None:
        raise AnswerError(f"expected a number, got {text!r}")
    if isinstance(text, (int, float)):
        if not math.isfinite(text):
            raise AnswerError("expected a finite number")
        return float(text)
    tree = check_text(str(text).strip(), ())
    try:
        return evaluate(tree, {})
    except Undefined as exc:
        raise AnswerError(f"it has no finite real value ({exc})") from None


def parse(text: str, symbols: tuple[str, ...] = ()):
    """The answer as a sympy expression, after the whitelist check: parse_expr with a dictionary of
    exactly the allowed symbols, functions and constants, and no other name (no auto-symbols)."""
    check_text(text, symbols)
    import sympy
    from sympy.parsing.sympy_parser import auto_number, parse_expr

    names = {"sqrt": sympy.sqrt, "sin": sympy.sin, "cos": sympy.cos, "tan": sympy.tan, "atan": sympy.atan,
             "atan2": sympy.atan2, "exp": sympy.exp, "log": sympy.log, "Abs": sympy.Abs, "abs": sympy.Abs,
             "pi": sympy.pi, "e": sympy.E}
    names.update({name: sympy.Symbol(name, real=True) for name in symbols})
    global_names = {"Integer": sympy.Integer, "Float": sympy.Float, "Rational": sympy.Rational,
                    "__builtins__": {}}
    try:
        return parse_expr(text.replace("^", "**"), local_dict=names, global_dict=global_names,
                          transformations=(auto_number,), evaluate=True)
    except Exception as exc:  # noqa: BLE001  sympy's own errors on a whitelisted tree: report, never crash
        raise AnswerError(f"cannot read it as a formula ({type(exc).__name__})") from None


class Simplifier:
    """sympy's simplify in a separate process, where it can be stopped.

    sympy's simplify on an allowed but hostile expression (exp(exp(exp(exp(exp(100)))))) runs for many
    seconds in C-level big-number code that no thread can interrupt. So it runs in a child
    interpreter of its own, started on first use (importing sympy there does not count against
    SIMPLIFY_SECONDS), with CPU-time and memory limits (resource.setrlimit where the platform has
    it), and killed with its process group when an answer takes longer than SIMPLIFY_SECONDS or the
    learner's `deadline` (a time.monotonic() value) passes (then `out_of_time`). After a kill every
    further question to this Simplifier is undecided at once. Use it as a context manager: the process
    ends with the block."""

    def __init__(self, deadline: float | None = None) -> None:
        self.deadline = deadline
        self.process: subprocess.Popen | None = None
        self.stopped = False
        self.out_of_time = False  # stopped because the learner's deadline came first
        self._buffer = b""

    def __enter__(self) -> Simplifier:
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    def _wait(self, seconds: float) -> bytes | None:
        """The worker's next line within `seconds` and before the deadline; None if none came."""
        limit = time.monotonic() + seconds
        until = limit if self.deadline is None else min(limit, self.deadline)
        line = self._line(until)
        if line is None and until < limit:
            self.out_of_time = True
        return line or None

    def _start(self) -> bool:
        from grader.spawn import child_environment, child_path

        # no -I/-E: the environment is grader.spawn's own (no PYTHONPATH), and its PYTHONHASHSEED=0 makes
        # sympy's term order, and so its verdict, the same on every run
        command = [sys.executable, "-S", "-c", _WORKER_BOOT.format(child_path())]
        try:
            self.process = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                            stderr=subprocess.DEVNULL, bufsize=0, start_new_session=True,
                                            env=child_environment())
        except OSError:
            return False
        return self._wait(SYMPY_START_SECONDS) == b"ready"

    def _line(self, until: float) -> bytes | None:
        """The worker's next line; None if none came by `until`, b"" if the worker ended."""
        fd = self.process.stdout.fileno()
        with selectors.DefaultSelector() as selector:
            selector.register(fd, selectors.EVENT_READ)
            while b"\n" not in self._buffer:
                remaining = until - time.monotonic()
                if remaining <= 0 or not selector.select(remaining):
                    return None
                chunk = os.read(fd, 4096)
                if not chunk:
                    return b""
                self._buffer += chunk
        line, self._buffer = self._buffer.split(b"\n", 1)
        return line.strip() or b"?"

    def is_zero(self, answer: str, key: str, symbols: tuple[str, ...]) -> bool | None:
        """Whether simplify(answer - key) == 0; None when sympy could not decide it in time (or failed)."""
        if self.stopped:
            return None
        if self.process is None and not self._start():
            self._stop()
            return None
        job = json.dumps({"answer": answer, "key": key, "symbols": list(symbols)}).encode() + b"\n"
        try:
            self.process.stdin.write(job)
        except OSError:
            self._stop()
            return None
        verdict = self._wait(SIMPLIFY_SECONDS)
        if verdict not in (b"true", b"false", b"error"):
            self._stop()
            return None
        return None if verdict == b"error" else verdict == b"true"

    def _stop(self) -> None:
        self.close()
        self.stopped = True

    def close(self) -> None:
        """Kill the worker and everything it started."""
        if self.process is None:
            return
        try:
            os.killpg(self.process.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass
        self.process.wait()
        self.process.stdin.close()
        self.process.stdout.close()
        self.process = None


SYMPY_START_SECONDS = 30.0  # a fresh interpreter importing sympy (about 0.4 s; more on a loaded machine)
SYMPY_CPU_SECONDS = 60  # a backstop: the worker is killed at its wall-clock time limits anyway
SYMPY_MEMORY_BYTES = 2 << 30
_WORKER_BOOT = "import sys; sys.path[:] = {!r}; from grader.quiz.symbolic import _worker; _worker()  # grader-sympy"


def _worker() -> None:
    """The Simplifier's process: limit itself, import sympy, say 'ready', then answer one job a line
    (true, false, or error when sympy fails) until its input ends."""
    try:
        import resource

        for limit, value in ((resource.RLIMIT_CPU, SYMPY_CPU_SECONDS), (resource.RLIMIT_AS, SYMPY_MEMORY_BYTES),
                             (resource.RLIMIT_CORE, 0)):
            try:
                resource.setrlimit(limit, (value, value))
            except (ValueError, OSError):
                pass
    except ImportError:  # not on this platform: the wall-clock kill still holds
        pass
    import sympy

    out = sys.stdout.buffer
    out.write(b"ready\n")
    out.flush()
    for line in iter(sys.stdin.buffer.readline, b""):
        try:
            job = json.loads(line)
            symbols = tuple(job["symbols"])
            same = bool(sympy.simplify(parse(job["answer"], symbols) - parse(job["key"], symbols)) == 0)
            out.write(b"true\n" if same else b"false\n")
        except Exception:  # noqa: BLE001  sympy's failure to decide is never "equal"
            out.write(b"error\n")
        out.flush()


def _simplify_is_zero(answer: str, key: str, symbols: tuple[str, ...], deadline: float | None = None) -> bool | None:
    """simplify(answer - key) == 0 in a Simplifier of its own; None if undecided in time."""
    with Simplifier(deadline) as simplifier:
        return simplifier.is_zero(answer, key, symbols)


def equivalent(answer: str, key: str, symbols: tuple[str, ...],
               domain: dict[str, tuple[float, float]] | None = None, seed: int = 0,
               simplifier: Simplifier | None = None) -> bool | None:
    """Whether two expression texts are the same function of `symbols` (see the module docstring):
    True or False, or None when sympy had to decide and could not in time (never "equal").
    `domain` maps a symbol to its (low, high) range; others are drawn from +-DEFAULT_DOMAIN.
    `simplifier` is the Simplifier to ask if sympy must decide (else one of its own).
    AnswerError if `answer` cannot be read."""
    answer_tree = check_text(answer, symbols)
    key_tree = check_text(key, symbols)
    domain = domain or {}
    draw = random.Random(seed)
    agree = 0
    for _ in range(NUMERIC_POINTS * 4):
        point = {}
        for name in symbols:
            if name in domain:
                point[name] = draw.uniform(*domain[name])
            else:
                point[name] = draw.choice((-1, 1)) * draw.uniform(*DEFAULT_DOMAIN)
        try:
            a, k = evaluate(answer_tree, point), evaluate(key_tree, point)
        except Undefined:
            continue
        if abs(a - k) > RELATIVE_TOLERANCE * max(1.0, abs(a), abs(k)):
            return False  # a point where both are defined and differ: not the same function
        agree += 1
        if agree >= NUMERIC_POINTS:
            return True
    if agree >= MIN_POINTS:
        return True
    if simplifier is not None:
        return simplifier.is_zero(answer, key, symbols)
    return _simplify_is_zero(answer, key, symbols)
