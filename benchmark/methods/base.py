"""The method contract every plug-in implements (docs/methods.md).

A method turns one :class:`~benchmark.methods.contract.Utterance` (16 kHz mono
speech, subject, sentence, split, frame count) into ``S`` samples of either the 32
BlendVOCA blendshape coefficients or the speaker's mesh vertices, at 60 fps, as its
:attr:`Method.output` declares. It may be trained on the BlendVOCA train/val splits
under a :class:`Budget`, and it can save and reload its trained state.
"""

from __future__ import annotations

import abc
import json
from pathlib import Path

from blendvoca.runtime.progress import progress_bars, show_progress

from .contract import OUTPUT_COEFFICIENTS, OUTPUT_KINDS
from .request import CONTRACT, Budget, TrainingRequest

__all__ = ["CONFIG_FILE", "Budget", "Method", "TrainingRequest", "progress_bars", "show_progress"]

#: File in which :meth:`Method.save` stores the constructor config.
CONFIG_FILE = "method_config.json"

class Method(abc.ABC):
    """Base class of a speech-to-face method plug-in.

    Subclasses set :attr:`name`, :attr:`stochastic` and :attr:`output` and implement
    :meth:`generate`; trainable methods also implement :meth:`train`, and methods
    with learned state override :meth:`save` / :meth:`load` (calling the base
    versions so that the config travels with the state).

    The config round trip is part of the contract: ``type(m)(**m.config())`` builds
    an equivalent untrained method, so a result file's ``method.config`` rebuilds the
    method that produced it. Subclasses read their settings through
    :meth:`config` (or their own attributes), never through private state.

    Parameters
    ----------
    **config
        JSON-serialisable keyword arguments; stored unchanged and reported by
        :meth:`config` into the result file.
    """

    #: Registry name, e.g. ``"said"``.
    name: str = "method"
    #: True: the benchmark asks for and scores S samples per sentence.
    stochastic: bool = False
    #: What :meth:`generate` returns: ``"coefficients"`` (S, T, 32) in [0, 1], or
    #: ``"vertices"`` (S, T, V, 3) in metres on the speaker's topology.
    output: str = OUTPUT_COEFFICIENTS
    #: True for reference rows (ground truth, mean, static); the leaderboard shows
    #: them but never ranks them among the methods.
    reference: bool = False
    #: Leaderboard row name; None means the registry name.
    label: str | None = None
    #: False for a method whose ``train`` learns nothing that depends on the seed (it
    #: reads stored outputs or the build, as ``mesh-adapter`` does): ``benchmark.run
    #: --seeds`` refuses it, as it refuses reference methods and methods that do not
    #: override :meth:`train`.
    learns: bool = True
    #: Config keys that change only how a trained method samples (e.g. CDFace's
    #: ``control``): ``benchmark.run --checkpoint DIR --config KEY=VALUE`` may set them
    #: on a loaded method through :meth:`with_sampling_options`; any other key must
    #: equal the checkpoint's.
    sampling_options: tuple = ()
    #: False for a method whose output is looked up by (subject, sentence) in what it
    #: read from the corpus (the ground truth, oracle tracks, another method's stored
    #: outputs): it cannot animate a recording it has not seen, so ``python -m
    #: benchmark.generate`` refuses it.
    new_audio: bool = True
    #: The method contract of the ``train`` defined in this class body (v3:
    #: ``train(dataset, request)``); a subclass that overrides ``train`` declares it again.
    contract: int = CONTRACT

    @classmethod
    def config_schema(cls):
        """The config keys this method accepts, with types (a
        :class:`~benchmark.methods.config.ConfigSchema`), or None when it declares none.

        ``benchmark.run --config`` values are checked against it before any work.
        The default reads the ``__init__`` signature (annotations, defaults) and the
        class docstring's ``Parameters``; preset-based plug-ins extend it with their
        presets' keys; a constructor taking only ``**config`` declares nothing (its
        values are only parsed as JSON).
        """
        from .config import ConfigSchema

        if cls.__init__ is Method.__init__:
            return None
        return ConfigSchema.from_signature(cls.__init__, cls.__doc__)

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if cls.output not in OUTPUT_KINDS:
            raise TypeError(f"{cls.__name__}.output: expected one of {OUTPUT_KINDS}, got {cls.output!r}")

    def __init__(self, **config):
        try:
            json.dumps(config)
        except TypeError as exc:
            raise TypeError(f"{type(self).__name__}: config must be JSON-serialisable, got {config!r}") from exc
        self._config = dict(config)

    def config(self) -> dict:
        """The configuration that goes into the result file (JSON-serialisable);
        ``type(self)(**self.config())`` rebuilds the method."""
        return dict(self._config)

    def train(self, dataset, request: TrainingRequest) -> None:
        """Train on ``dataset.split("train")`` / ``("val")`` as ``request`` asks; default: nothing to train.

        Method contract v3 (docs/methods.md, "The contract"): a plug-in that overrides
        ``train`` declares ``contract = 3`` in the same class body
        (:func:`~benchmark.methods.request.train_contract`); one that does not is called as a
        contract-v2 plug-in, ``train(dataset, *, seed, budget)``, with a ``DeprecationWarning``.

        Parameters
        ----------
        dataset : benchmark.data dataset
            As returned by ``benchmark.data.open_blendvoca``; vertex-trained methods
            read ``dataset.vertices(subject, sentence)`` and ``dataset.template(subject)``
            (the source meshes, or on a build without them the speaker's rig at the
            ground-truth coefficients: ``dataset.vertex_space``), and size themselves from them.
        request : TrainingRequest
            The seed, the budget, the device and the runner's checkpoint hook with its
            fractions (the hook's rules: docs/methods.md, "Settled or not"; the bundled
            baselines make the calls through
            :class:`benchmark.methods.training_loop.StepLoop`).
        """
        return

    @abc.abstractmethod
    def generate(self, utterance, *, samples: int = 1, seed: int = 0):
        """Animation for one utterance.

        Parameters
        ----------
        utterance : benchmark.methods.contract.Utterance
            Subject, sentence, split, audio ((N,) float32 at 16 kHz) and
            ``num_frames`` (T at 60 fps).
        samples : int
            Number of samples ``S`` (1 for deterministic methods).
        seed : int
            Seed for stochastic sampling.

        Returns
        -------
        (S, T, 32) ndarray
            ``output == "coefficients"``: values in [0, 1], columns in
            ``benchmark.methods.contract.COEFFICIENT_NAMES`` order.
        (S, T, V, 3) ndarray
            ``output == "vertices"``: metres, on the speaker's topology
            (``dataset.template(subject)``).
        """

    def styles(self) -> tuple[str, ...] | None:
        """The speakers this (trained) method can animate, the values ``Utterance.subject``
        may take outside the corpus, first the default one; None when its output does not
        depend on the speaker (the default).

        A vertex method returns the speakers whose template it holds (the output is on
        that speaker's face); ``python -m benchmark.generate --style S`` picks one.
        """
        return None

    def generate_many(self, utterances, *, samples: int = 1, seeds) -> list:
        """Animations for several utterances, one seed each (``benchmark.run --sentence-batch N``).

        The default asks :meth:`generate` for each in turn; a method that can batch
        sentences (SAiD pads them into one batch) overrides it.

        Returns
        -------
        list
            One :meth:`generate` output per utterance, in order.
        """
        return [self.generate(utterance, samples=samples, seed=seed) for utterance, seed in zip(utterances, seeds)]

    def save(self, directory) -> None:
        """Write the config (and, in subclasses, the trained state) into ``directory``."""
        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        payload = {"name": self.name, "class": f"{type(self).__module__}:{type(self).__qualname__}",
                   "config": self.config()}
        (directory / CONFIG_FILE).write_text(json.dumps(payload, indent=2, sort_keys=True) + "\n")

    @classmethod
    def load(cls, directory) -> Method:
        """Rebuild a method from :meth:`save`'s output (config only in the base class)."""
        path = Path(directory) / CONFIG_FILE
        if not path.is_file():
            raise FileNotFoundError(f"{cls.__name__}.load: expected {path} (written by save), not found")
        payload = json.loads(path.read_text())
        return cls(**payload.get("config", {}))

    def with_sampling_options(self, **options) -> Method:
        """This trained method with the :attr:`sampling_options` ``options`` changed.

        The base class declares none; a subclass that declares some overrides this
        (typically ``twin = type(self)(**{**self.config(), **options})`` sharing the
        trained state), so that the new method's :meth:`config` reports the options.
        """
        self.check_sampling_options(options)
        if options:
            raise NotImplementedError(f"{type(self).__name__} declares sampling options but does not "
                                      "override with_sampling_options")
        return self

    def check_sampling_options(self, options) -> None:
        """ValueError unless every key of ``options`` is one of :attr:`sampling_options`."""
        unknown = sorted(set(options) - set(self.sampling_options))
        if unknown:
            raise ValueError(f"{type(self).__name__}: {unknown} are not sampling options "
                             f"(expected some of {list(self.sampling_options)})")

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in sorted(self.config().items()))
        return f"{type(self).__name__}({args})"
