"""The protocol's first step: the method ready to generate, built and trained or
loaded from a checkpoint (and saved to one when asked)."""

from __future__ import annotations

import json
import os
import pickle
import sys
import time
import zipfile
from dataclasses import dataclass
from pathlib import Path

from benchmark.methods import OUTPUT_COEFFICIENTS, Budget, get_method
from benchmark.methods.base import CONFIG_FILE
from benchmark.methods.request import CONTRACT, TrainingRequest, call_train
from benchmark.protocol.isolation import plugin_call, warn_notes
from benchmark.protocol.limits import TimeLimit
from blendvoca.errors import DataError, MethodError, MethodTimeout, UserError, out_of_resources, ran_out_of

__all__ = ["TRAIN_GRACE_S", "Trained", "make_method", "moved_to", "prepared_method",
           "train"]

#: Extra seconds over ``Budget.max_seconds`` before the runner stops a training run.
TRAIN_GRACE_S = 60.0

#: What reading a file that is no checkpoint at all raises (pickle, zip and text readers).
_NOT_A_CHECKPOINT = (pickle.UnpicklingError, EOFError, zipfile.BadZipFile, UnicodeDecodeError)

def moved_to(method, device):
    """``method`` ready to generate on ``device``: ``method.to(device)`` when the method
    has a ``to`` (it returns the moved method, or None for itself); a method without one
    generates where it is. None changes nothing.

    Raises
    ------
    MethodError
        The method's ``to`` raised.
    """
    mover = getattr(method, "to", None)
    if device is None or not callable(mover):
        return method
    try:
        moved = mover(device)
    except Exception as exc:
        raise MethodError(f"method {getattr(method, 'name', type(method).__name__)!r}: moving it to {device} "
                          f"failed: {type(exc).__name__}: {exc}") from exc
    return method if moved is None else moved


@dataclass(frozen=True)
class Trained:
    """A method ready to generate.

    Attributes
    ----------
    method : Method
    name : str
        The name the run asked for (registered or installed).
    train_s, load_s : float or None
        Seconds spent training (without the half-budget check's), or loading a
        checkpoint (the other one is None).
    convergence_s : float or None
        Seconds spent in the half-budget check (generating and scoring), None without one.
    """

    method: object
    name: str
    train_s: float | None = None
    load_s: float | None = None
    convergence_s: float | None = None

    @property
    def timings(self) -> dict:
        """``{"train_s": ..., "load_s": ..., "convergence_s": ...}`` as a result file records them."""
        return {"train_s": self.train_s, "load_s": self.load_s, "convergence_s": self.convergence_s}

    @property
    def stochastic(self) -> bool:
        return bool(getattr(self.method, "stochastic", False))

    @property
    def output(self) -> str:
        """``"coefficients"`` or ``"vertices"`` (:data:`benchmark.methods.OUTPUT_KINDS`)."""
        return getattr(self.method, "output", OUTPUT_COEFFICIENTS)

    @property
    def label(self) -> str:
        """The method's display label, else its name."""
        return getattr(self.method, "label", None) or self.name


def train(spec, dataset, *, check=None) -> Trained:
    """The method of ``spec`` ready to generate (:func:`prepared_method`).

    Parameters
    ----------
    spec : RunSpec
    dataset : benchmark.data dataset
    check : benchmark.protocol.convergence.HalfBudgetCheck, optional
        The half-budget check, handed to the method's ``train`` as ``on_checkpoint``;
        its seconds are counted in ``convergence_s``, not ``train_s``.

    The device is ``spec.device`` (``benchmark.run --device``); None leaves it to each
    method.

    Returns
    -------
    Trained
    """
    device = getattr(spec, "device", None)
    method, timings = prepared_method(spec.method, spec.config, dataset, seed=spec.seed, budget=spec.budget,
                                      checkpoint=spec.checkpoint, checkpoint_hook=check, device=device)
    train_s, convergence_s = timings["train_s"], None
    if check is not None and check.called:
        convergence_s = check.seconds
        train_s = None if train_s is None else max(0.0, train_s - check.seconds)
    return Trained(method=method, name=spec.method, train_s=train_s, load_s=timings["load_s"],
                   convergence_s=convergence_s)


def make_method(name: str, config: dict | None = None):
    """Instantiate the registered method ``name`` with ``config``.

    Raises
    ------
    MethodError
        The constructor raised (e.g. an unknown config key).
    """
    cls = get_method(name)
    try:
        return cls(**(config or {}))
    except Exception as exc:
        raise MethodError(f"method {name!r}: construction with config {config!r} failed: "
                          f"{type(exc).__name__}: {exc}") from exc


def prepared_method(name: str, config: dict, dataset, *, seed: int, budget: Budget, checkpoint=None,
                    checkpoint_hook=None, device=None):
    """The method ready to generate: loaded from ``checkpoint`` when it holds one,
    otherwise built and trained (and saved to ``checkpoint`` when given).

    Parameters
    ----------
    name : str
    config : dict
        Constructor kwargs; on a loaded checkpoint only its sampling options may differ.
    dataset : benchmark.data dataset
    seed : int
    budget : Budget
    checkpoint : str or path-like, optional
        A folder written by the method's ``save`` (loaded), an empty or missing folder
        (trained and saved there), or a file: the method's released weights
        (``from_official_checkpoint``).
    checkpoint_hook : callable, optional
        ``checkpoint_hook(method, step, total_steps)``, handed to a method that is
        trained (not loaded) as the request's ``on_checkpoint(step, total_steps=None)``
        (``Method.train``). What the hook raises leaves ``train`` unchanged (not wrapped as
        the method's failure). Its ``fractions`` attribute, when it has one, is the
        request's ``checkpoint_fractions`` (the learning curve's checkpoints).
    device : str, optional
        ``"cpu"``, ``"cuda"`` or ``"cuda:N"`` (:func:`blendvoca.cli.checked_device`): the
        request's ``device``, and the trained or loaded method is then moved there
        (:func:`moved_to`) to generate. None: each method trains and generates where it
        always did.

    The method is called through :func:`benchmark.methods.request.call_train` (contract
    v3, ``train(dataset, request)``; a contract-v2 plug-in with one ``DeprecationWarning``).

    Returns
    -------
    method : Method
    timings : dict
        ``{"train_s": ..., "load_s": ...}`` (one of them None).

    Raises
    ------
    UserError
        ``checkpoint`` cannot be used: a file this method does not read, a folder of
        another method or of no method, a place a folder cannot be made; or ``config``
        changes more than the checkpoint's sampling options.
    DataError, OSError
        Training read a file of the build that is wrong or missing (the project's
        readers say so; raised unchanged).
    MethodError
        The method raised while training, saving, or loading its own checkpoint.
    MethodTimeout
        Training ran past the budget's seconds (plus :data:`TRAIN_GRACE_S`).
    """
    cls = get_method(name)
    timings = {"train_s": None, "load_s": None}
    config = dict(config or {})
    path = None if checkpoint is None else Path(os.fspath(checkpoint))
    if path is not None and path.is_file():
        start = time.perf_counter()
        method = _from_released_file(cls, name, config, dataset, seed=seed, budget=budget, path=path)
        method = moved_to(method, device)
        timings["load_s"] = time.perf_counter() - start
        return method, timings
    if path is not None and path.is_dir() and any(path.iterdir()):
        start = time.perf_counter()
        method = moved_to(_with_config(_from_folder(cls, name, path), config, name, path), device)
        timings["load_s"] = time.perf_counter() - start
        return method, timings
    if path is not None:
        _check_creatable(path)  # before training, not after it
    method = make_method(name, config)
    start = time.perf_counter()
    limit = None if budget.max_seconds is None else budget.max_seconds * 1.1 + TRAIN_GRACE_S
    raised = []
    on_checkpoint = None
    if checkpoint_hook is not None:
        def on_checkpoint(step, total_steps=None):
            try:
                checkpoint_hook(method, step, total_steps)
            except BaseException as exc:
                raised.append(exc)
                raise

    # the check says where it wants its calls (its fractions of the step budget)
    fractions = getattr(checkpoint_hook, "fractions", (0.5,))
    request = TrainingRequest(seed=seed, budget=budget, device=device, on_checkpoint=on_checkpoint,
                              checkpoint_fractions=fractions)
    notes = []
    try:
        with plugin_call(f"method {name!r}: train", notes=notes), \
                TimeLimit(limit, f"method {name!r}: train (budget {budget.max_seconds:g} s + grace)" if limit else ""):
            call_train(method, dataset, request)
    except (MethodTimeout, UserError, DataError, OSError):
        # a build file that is missing or wrong is the data's fault, not the method's
        if ran_out_of(sys.exc_info()[1]) is not None:
            raise out_of_resources(sys.exc_info()[1], f"method {name!r}: train") from None
        raise
    except MemoryError as exc:
        raise out_of_resources(exc, f"method {name!r}: train") from exc
    except Exception as exc:
        if ran_out_of(exc) is not None:  # torch's allocator: memory, not the method's fault
            raise out_of_resources(exc, f"method {name!r}: train") from exc
        for error in raised:  # the check's own failure (e.g. the half-trained method's output), unwrapped
            if _caused_by(exc, error):
                raise error from None
        contract = f" (method contract v{CONTRACT}: train(dataset, request))" if isinstance(exc, TypeError) else ""
        raise MethodError(f"method {name!r}: train failed{contract}: {type(exc).__name__}: {exc}") from exc
    finally:
        warn_notes(notes)
    method = moved_to(method, device)
    timings["train_s"] = time.perf_counter() - start
    if path is not None:
        try:
            method.save(path)
        except OSError as exc:
            raise UserError(f"--checkpoint {path}: cannot save the trained method there: "
                            f"{exc.strerror or exc}") from exc
        except Exception as exc:
            raise MethodError(f"method {name!r}: save to {path} failed: {type(exc).__name__}: {exc}") from exc
    return method, timings


def _caused_by(exc: BaseException, cause: BaseException) -> bool:
    """Whether ``cause`` is ``exc`` or in its chain of causes and contexts."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if exc is cause:
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


def _from_released_file(cls, name: str, config: dict, dataset, *, seed: int, budget: Budget, path: Path):
    """A method from its released weights file: ``from_official_checkpoint(path, **config)``,
    then ``train``, which only reads what the method needs from the dataset (templates).

    The runner cannot tell another method's weights from a method failing on its own:
    what the loader says about the file (an unreadable or foreign file, a missing
    companion file) is the user's to fix; anything else is the method's.
    """
    loader = getattr(cls, "from_official_checkpoint", None)
    if loader is None:
        raise UserError(f"method {name!r}: --checkpoint {path} is a file, but this method loads only "
                        f"directories written by its save()")
    _check_archive(path)
    try:
        method = loader(str(path), **config)
        call_train(method, dataset, TrainingRequest(seed=seed, budget=budget))
    except (UserError, DataError):
        raise
    except MethodError as exc:
        raise MethodError(f"method {name!r}: loading {path} failed: {type(exc).__name__}: {exc}") from exc
    except (OSError, ValueError, KeyError, *_NOT_A_CHECKPOINT) as exc:
        raise UserError(f"--checkpoint {path}: method {name!r} cannot load this file as its released weights: "
                        f"{type(exc).__name__}: {exc}") from exc
    except Exception as exc:
        raise MethodError(f"method {name!r}: loading {path} failed: {type(exc).__name__}: {exc}") from exc
    return method


def _check_archive(path: Path) -> None:
    """UserError for a zip archive (PyTorch's format, ``.npz``) cut short: it cannot be
    any checkpoint, whichever method reads it."""
    with open(path, "rb") as handle:
        head = handle.read(4)
    if head == b"PK\x03\x04" and not zipfile.is_zipfile(path):
        raise UserError(f"--checkpoint {path}: a damaged zip archive (truncated or incomplete copy?), "
                        "not a checkpoint")


def _from_folder(cls, name: str, path: Path):
    """A method from a folder written by its ``save``: the folder's config names the
    method (another method's folder, or one with no config, is the user's mistake);
    what fails after that is the method failing on its own checkpoint."""
    saved = path / CONFIG_FILE
    if not saved.is_file():
        raise UserError(f"--checkpoint {path}: not a method checkpoint (no {CONFIG_FILE}); expected an empty "
                        f"folder, a folder written by a method's save() or a released weights file")
    try:
        saved_name = json.loads(saved.read_text(encoding="utf-8")).get("name")
    except (UnicodeDecodeError, json.JSONDecodeError, AttributeError) as exc:
        raise UserError(f"--checkpoint {path}: {CONFIG_FILE} does not read as a method config ({exc})") from None
    if saved_name not in (None, name, getattr(cls, "name", None)):
        raise UserError(f"method {name!r}: checkpoint {path} holds method {saved_name!r}, not {name!r}")
    try:
        return cls.load(path)
    except (UserError, DataError):
        raise
    except Exception as exc:
        raise MethodError(f"method {name!r}: load from {path} failed: {type(exc).__name__}: {exc}") from exc


def _check_creatable(path: Path) -> None:
    """UserError unless a checkpoint folder can be made at ``path`` (the nearest existing
    folder above it is writable)."""
    if path.exists() and not path.is_dir():
        raise UserError(f"--checkpoint {path}: expected a folder or a weights file, got neither")
    parent = path
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir():
        raise UserError(f"--checkpoint {path}: {parent} is a file, so no folder can be made there")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise UserError(f"--checkpoint {path}: cannot make a folder in {parent} (not writable)")


def _with_config(method, config: dict, name: str, checkpoint):
    """A loaded method with the ``--config`` entries that differ from its saved config applied:
    sampling options (``method.sampling_options``) are set, anything else is a user error
    (the checkpoint was trained with another value; retrain instead)."""
    saved = method.config()
    missing = object()
    changed = {k: v for k, v in config.items() if saved.get(k, missing) != v}
    fixed = sorted(k for k in changed if k not in method.sampling_options)
    if fixed:
        given = ", ".join(f"{k}={changed[k]!r}" for k in fixed)
        trained = ", ".join(f"{k}={saved[k]!r}" if k in saved else f"{k} unset" for k in fixed)
        options = list(method.sampling_options) or "none"
        raise UserError(f"method {name!r}: --config {given} differs from the checkpoint {checkpoint} (trained with "
                        f"{trained}); only sampling options can change after training (here: {options})")
    if not changed:
        return method
    try:
        return method.with_sampling_options(**changed)
    except Exception as exc:
        raise MethodError(f"method {name!r}: sampling options {changed} on {checkpoint} failed: "
                          f"{type(exc).__name__}: {exc}") from exc
