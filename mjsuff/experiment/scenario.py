"""Scenario files: TOML, validated on load into a fully resolved, typed configuration.

Every error names the file, the dotted key and what was expected, in one line (``ScenarioError``).
Overrides (``--set KEY=VALUE``) are applied before validation; VALUE is read as a TOML value
(``0.9``, ``[0.1, 0.2]``, ``"active"``) and falls back to a plain string.
"""

from __future__ import annotations

import copy
import itertools
import json
import math
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal, get_args

import tomli_w
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator
from pydantic_core import ErrorDetails

from mjsuff.bounds.var_bound import QuantileMethod, least_effective_size
from mjsuff.domains import REGISTRY, UnknownDomainError, get_domain
from mjsuff.errors import MjsuffError
from mjsuff.experiment.shipped_scenarios import shipped_scenario_files
from mjsuff.posterior.sampler import SamplerConfig


class ScenarioError(MjsuffError, ValueError):
    """A scenario file or override that cannot be used; the message is one line for the user."""


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, strict=True, allow_inf_nan=False)


class DomainSettings(_Strict):
    name: str = Field(description=f"registered domain ({sorted(REGISTRY)}) or module:attribute")
    params: dict[str, Any] = Field(default_factory=dict, description="domain parameters")


class DemoSettings(_Strict):
    max_demos: int | None = Field(None, ge=1, description="demos per replicate (default: pool)")
    selection: Literal["passive", "active"] = "passive"
    noise_fraction: float = Field(0.0, ge=0.0, lt=1.0, description="share of poor demos")
    beta: float = Field(10.0, gt=0.0, le=1000.0, description="Boltzmann rationality of the likelihood")
    lapse: float = Field(
        0.0,
        ge=0.0,
        lt=1.0,
        description="lapse rate of the likelihood: the chance the demonstrator picks uniformly among "
        "a demo's alternatives (0: the paper's Boltzmann likelihood)",
    )


class SufficiencySettings(_Strict):
    alpha: float = Field(0.95, gt=0.0, lt=1.0, description="VaR quantile level")
    delta: float = Field(0.05, gt=0.0, lt=1.0, description="1 - confidence of the bound")
    quantile_method: QuantileMethod = "normal"


Threshold = Annotated[float, Field(gt=0.0, le=1.0)]
Improvement = Annotated[float, Field(gt=0.0)]
Patience = Annotated[int, Field(ge=1)]
Interval = Annotated[int, Field(ge=2)]


class RuleSettings(_Strict):
    nevd_thresholds: list[Threshold] = [0.1, 0.2, 0.3, 0.4, 0.5]
    piob_thresholds: list[Improvement] = [0.2, 0.4, 0.6]
    patience: list[Patience] = [1, 2, 3, 4, 5]
    validation_intervals: list[Interval] = [3, 4, 5, 6, 7]
    validation_min_held_out: int = Field(3, ge=1, description="held-out demos before it may stop")

    @model_validator(mode="after")
    def _no_duplicates(self) -> RuleSettings:
        # A rule parameter given twice would run twice and count twice in every summary and test.
        for key in ("nevd_thresholds", "piob_thresholds", "patience", "validation_intervals"):
            values = getattr(self, key)
            twice = sorted({v for v in values if values.count(v) > 1})
            if twice:
                raise ValueError(f"rules.{key}: {', '.join(f'{v:g}' for v in twice)} given more than once")
        return self


#: A name that can be a file name anywhere: no separators, no leading dot (so never ``..``).
SAFE_NAME = r"^[A-Za-z0-9_][A-Za-z0-9._-]*$"
#: The most replicates a run (all its sweep cells) may plan: each is a file of its own, and at
#: a second apiece 100,000 replicates are a day of a large machine's cores.
MAX_REPLICATES = 100_000


class Scenario(_Strict):
    """A fully resolved experiment: what to run, how many times, and with which settings."""

    name: str = Field(
        min_length=1,
        max_length=100,
        description="the run's name: letters, digits, '.', '_', '-' (it names runs/NAME-TIMESTAMP)",
    )
    seed: int = Field(0, ge=0)
    replicates: int = Field(
        20, ge=1, le=MAX_REPLICATES, description=f"replicates per sweep cell (at most {MAX_REPLICATES:,})"
    )
    domain: DomainSettings
    demos: DemoSettings = DemoSettings()
    posterior: SamplerConfig = SamplerConfig()
    sufficiency: SufficiencySettings = SufficiencySettings()
    rules: RuleSettings = RuleSettings()
    sweep: dict[str, list[Any]] = Field(
        default_factory=dict,
        description="grid: dotted scenario key -> values; every combination "
        "is a cell run with the same seeds (see ``cells``)",
    )

    @field_validator("name")
    @classmethod
    def _safe_name(cls, name: str) -> str:
        if not re.fullmatch(SAFE_NAME, name):
            raise ValueError(
                "expected letters, digits, '.', '_' or '-', not starting with '.' "
                "(the name becomes a file name: runs/NAME-TIMESTAMP)"
            )
        return name

    @model_validator(mode="after")
    def _consistent(self) -> Scenario:
        r = self.rules
        if not (r.nevd_thresholds or r.piob_thresholds or r.patience or r.validation_intervals):
            raise ValueError("rules: at least one rule is needed")
        if (r.patience or r.validation_intervals) and not r.nevd_thresholds:
            raise ValueError(
                "rules.nevd_thresholds: the baselines are scored at the nEVD "
                "thresholds, so at least one is needed"
            )
        cells = math.prod(len(v) for v in self.sweep.values()) if self.sweep else 1
        if cells * self.replicates > MAX_REPLICATES:
            raise ValueError(
                f"replicates: {cells} sweep cells × {self.replicates:,} replicates plan more than "
                f"{MAX_REPLICATES:,} replicates"
            )
        a, d, q = self.sufficiency.alpha, self.sufficiency.delta, self.sufficiency.quantile_method
        n = self.posterior.num_samples
        least = least_effective_size(n, a, d, q)
        if least is None:
            needed = next(m for m in range(n, 100_000) if least_effective_size(m, a, d, q))
            raise ValueError(
                f"posterior.num_samples: at least {needed} samples are needed for a "
                f"{1 - d:g}-confidence bound on the {a:g}-VaR ({q} order statistic; "
                f"got {n})"
            )
        if self.posterior.min_ess is not None and self.posterior.min_ess < least:
            raise ValueError(
                f"posterior.min_ess: the {1 - d:g}-confidence bound on the {a:g}-VaR "
                f"from {n} samples needs an effective size of at least {least} "
                f"(got {self.posterior.min_ess:g})"
            )
        return self

    def cells(self, source: str = "scenario") -> list[SweepCell]:
        """Every combination of the sweep's values (the scenario itself when there is no sweep),
        each a validated scenario without a sweep. Errors name ``source`` and ``sweep.KEY``."""
        if not self.sweep:
            return [SweepCell(0, {}, self)]
        base = self.model_dump(mode="json", exclude_none=True)
        del base["sweep"]
        keys = list(self.sweep)
        for key in keys:
            if key.split(".")[0] in _UNSWEEPABLE or not self.sweep[key]:
                raise ScenarioError(
                    f"{source}: sweep.{key}: expected a non-empty list of values for a scenario key "
                    f"other than {', '.join(sorted(_UNSWEEPABLE))}"
                )
        cells = []
        for index, values in enumerate(itertools.product(*(self.sweep[k] for k in keys))):
            labels = dict(zip(keys, values, strict=True))
            data = copy.deepcopy(base)
            for key, value in labels.items():
                _set_dotted(data, key.split("."), value, f"{source}: sweep.{key}")
            try:
                cell = scenario_from_dict(data, f"{source}: sweep cell {_label(labels)}")
            except ScenarioError as exc:
                raise ScenarioError(str(exc)) from None
            cells.append(SweepCell(index, labels, cell))
        return cells

    def sampler(self) -> SamplerConfig:
        """The posterior settings with ``min_ess`` resolved: as set, else 0.4 × ``num_samples`` or
        the effective size the α-VaR bound needs, whichever is larger."""
        if self.posterior.min_ess is not None:
            return self.posterior
        s = self.sufficiency
        least = least_effective_size(self.posterior.num_samples, s.alpha, s.delta, s.quantile_method)
        return self.posterior.model_copy(
            update={"min_ess": float(max(self.posterior.ess_target, least or 0))}
        )

    def domain_params(self) -> BaseModel:
        return get_domain(self.domain.name).params.model_validate(self.domain.params)

    def to_toml(self) -> str:
        """The resolved scenario (domain defaults filled in) as TOML, enough to rerun it."""
        data = self.model_dump(mode="json", exclude_none=True)
        data["domain"]["params"] = self.domain_params().model_dump(mode="json", exclude_none=True)
        return tomli_w.dumps(data)


def flat_keys(data: Any, prefix: str = "") -> dict[str, Any]:
    """``{"a": {"b": 1}}`` -> ``{"a.b": 1}``; lists become their JSON text (comparable, hashable)."""
    if isinstance(data, dict):
        out: dict[str, Any] = {}
        for k, v in data.items():
            out.update(flat_keys(v, f"{prefix}{k}."))
        return out
    return {prefix.rstrip("."): json.dumps(data) if isinstance(data, list) else data}


def scenario_default(key: str) -> Any:
    """The default of a dotted scenario setting outside the domain's own parameters (e.g.
    ``demos.lapse`` -> 0.0); ``None`` when it has none or is not a single setting. A key added to
    the scenario defaults to the behaviour before it existed, so this is also what an older run
    that lacks it ran with."""
    model: Any = Scenario
    *parents, last = key.split(".")
    for part in parents:
        field = model.model_fields.get(part)
        section = None if field is None else field.annotation
        if not (isinstance(section, type) and issubclass(section, BaseModel)):
            return None
        model = section
    field = model.model_fields.get(last)
    if field is None or field.is_required() or field.default_factory is not None:
        return None
    return None if isinstance(field.default, BaseModel) else field.default


def stored_settings(data: dict[str, Any], source: str) -> dict[str, Any]:
    """A run's stored ``config.toml`` (parsed) as flat keys (``flat_keys``), each key it lacks
    that was added since filled with its default: a key added to the scenario defaults to the
    behaviour before it existed, so that is what the run ran with (the domain's parameters too).
    A key that may be ``None`` is not filled: ``to_toml`` leaves ``None`` out, so its absence may
    be the ``None`` the run had, and a later default must not stand in for it.

    Raises:
        ScenarioError: The data no longer validates (a key since moved or removed); names ``source``.
    """
    scenario = scenario_from_dict(copy.deepcopy(data), source)
    stored = flat_keys(data)
    for key, value in flat_keys(tomllib.loads(scenario.to_toml())).items():
        if key not in stored and not _may_be_none(key, scenario.domain.name):
            stored[key] = value
    return stored


def _may_be_none(key: str, domain: str) -> bool:
    """Whether the setting at dotted ``key``, or a section above it, may be ``None`` (or is not a
    setting of the current models)."""
    parts = key.split(".")
    model: type[BaseModel] = Scenario
    if parts[:2] == ["domain", "params"]:
        model, parts = get_domain(domain).params, parts[2:]
    for depth, part in enumerate(parts):
        field = model.model_fields.get(part)
        if field is None:
            return True
        kinds = get_args(field.annotation) or (field.annotation,)
        if type(None) in kinds:
            return True
        if depth < len(parts) - 1:
            sections = [k for k in kinds if isinstance(k, type) and issubclass(k, BaseModel)]
            if not sections:
                return True
            model = sections[0]
    return False


_UNSWEEPABLE = {"name", "seed", "replicates", "sweep"}


def _label(labels: dict[str, Any]) -> str:
    return ", ".join(f"{k}={v}" for k, v in labels.items())


def _set_dotted(data: dict[str, Any], keys: list[str], value: Any, where: str) -> None:
    node = data
    for k in keys[:-1]:
        child = node.setdefault(k, {})
        if not isinstance(child, dict):
            raise ScenarioError(f"{where}: {k} is not a table")
        node = child
    node[keys[-1]] = value


@dataclass(frozen=True)
class SweepCell:
    """One combination of a sweep: its index, ``{dotted key: value}`` and resolved scenario."""

    index: int
    labels: dict[str, Any]
    scenario: Scenario

    @property
    def dirname(self) -> str:
        """``cell-NN_key=value_...`` (the last part of each key), safe as a directory name."""

        def text(v: Any) -> str:
            return "+".join(map(str, v)) if isinstance(v, list) else str(v)

        parts = [f"{k.split('.')[-1]}={text(v)}" for k, v in self.labels.items()]
        name = "_".join([f"cell-{self.index:02d}", *parts])
        return re.sub(r"[^A-Za-z0-9_.=+-]", "-", name)


def _error_key(error: ErrorDetails, prefix: tuple[Any, ...] = ()) -> str:
    """The dotted key an error is about: its location, and for a model's own check the key its
    message starts with (``"max_steps: ..."`` inside ``posterior`` is ``posterior.max_steps``)."""
    parts = [str(p) for p in (*prefix, *error["loc"])]
    if error["type"] == "value_error":
        head = error["msg"].removeprefix("Value error, ").split(":", 1)[0]
        if re.fullmatch(r"[a-z_]+(\.[a-z_]+)*", head) and not (parts and head.startswith(parts[0])):
            parts.append(head)
        elif re.fullmatch(r"[a-z_]+(\.[a-z_]+)*", head):
            parts = [head]
    return ".".join(parts)


def _describe(error: ErrorDetails, prefix: tuple[Any, ...] = ()) -> str:
    loc = ".".join(str(p) for p in (*prefix, *error["loc"]))
    if error["type"] == "value_error":
        message = error["msg"].removeprefix("Value error, ")
        key = _error_key(error, prefix)
        head, sep, rest = message.partition(": ")
        if sep and key.endswith(head):
            return f"{key}: {rest}"
        return f"{loc + ': ' if loc else ''}{message}"
    loc = loc or "(top level)"
    if error["type"] == "extra_forbidden":
        return f"{loc}: unknown key"
    if error["type"] == "missing":
        return f"{loc}: missing required key"
    return f"{loc}: {error['msg'].lower()} (got {error['input']!r})"


def parse_override(text: str) -> tuple[list[str], Any]:
    """``"a.b=VALUE"`` -> (["a", "b"], parsed VALUE)."""
    key, sep, raw = text.partition("=")
    if not sep or not key.strip():
        raise ScenarioError(f"--set {text!r}: expected KEY=VALUE, e.g. posterior.num_samples=200")
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw
    return key.strip().split("."), value


def apply_overrides(data: dict[str, Any], overrides: list[str]) -> dict[str, Any]:
    for text in overrides:
        keys, value = parse_override(text)
        _set_dotted(data, keys, value, f"--set {text!r}")
    return data


def _origin(source: str, error: ErrorDetails, prefix: tuple[Any, ...], overridden: Mapping[str, str]) -> str:
    """``source``, or ``source (OPTION)`` when the offending key came from an override."""
    dotted = _error_key(error, prefix)
    for key in sorted(overridden, key=len, reverse=True):
        if dotted == key or dotted.startswith(key + "."):
            return f"{source} ({overridden[key]})"
    return source


#: Scene settings that moved into the scene's parameters (issue #18): old key -> new key.
MOVED_KEYS = {
    "expert": "domain.params.expert",
    "demos.candidates": "domain.params.candidates",
    "rules.unchanged_tolerance": "domain.params.unchanged_tolerance",
    "rules.match_tolerance": "domain.params.match_tolerance",
}


def _moved_key(data: dict[str, Any]) -> str | None:
    """The first key of ``data`` that ``MOVED_KEYS`` lists, if any."""
    for old in MOVED_KEYS:
        node: Any = data
        for part in old.split("."):
            node = node.get(part) if isinstance(node, dict) else None
        if node is not None:
            return old
    return None


def scenario_from_dict(
    data: dict[str, Any], source: str, overridden: Mapping[str, str] | None = None
) -> Scenario:
    """Validate raw scenario data; ``source`` (and the option that set an ``overridden`` key,
    ``{dotted key: option}``) is named in errors."""
    overridden = overridden or {}
    moved = _moved_key(data)
    if moved is not None:
        given = [k for k in sorted(overridden) if k == moved or k.startswith(moved + ".")]
        where = f"{source} ({overridden[given[0]]})" if given else source
        raise ScenarioError(
            f"{where}: {moved}: a scene setting, now {MOVED_KEYS[moved]} (the scene's own parameters)"
        )
    try:
        scenario = Scenario.model_validate(data)
    except ValidationError as exc:
        error = exc.errors()[0]
        raise ScenarioError(f"{_origin(source, error, (), overridden)}: {_describe(error)}") from None
    try:
        get_domain(scenario.domain.name)
    except UnknownDomainError as exc:
        raise ScenarioError(f"{source}: domain.name: {exc}") from None
    try:
        scenario.domain_params()
    except ValidationError as exc:
        error, prefix = exc.errors()[0], ("domain", "params")
        raise ScenarioError(
            f"{_origin(source, error, prefix, overridden)}: {_describe(error, prefix)}"
        ) from None
    return scenario


def resolve_scenario(path: str | Path) -> Path:
    """The scenario file ``path`` names: the file itself if there is one or ``path`` is not a bare
    name (it has a directory part or a ``.toml`` suffix), else the shipped scenario of that name;
    a one-line ``ScenarioError`` listing the shipped names if there is none."""
    given = Path(path)
    if given.is_file() or len(given.parts) != 1 or given.suffix == ".toml":
        return given
    shipped = shipped_scenario_files()
    if given.name in shipped:
        return shipped[given.name]
    if given.exists():
        return given  # a directory: load_scenario says so
    raise ScenarioError(
        f"{path}: no such scenario file, nor a shipped scenario (shipped: {', '.join(shipped) or 'none'})"
    )


def load_scenario(
    path: str | Path, overrides: list[str] | None = None, given_as: Mapping[str, str] | None = None
) -> Scenario:
    """Read, override and validate a scenario file, or the shipped scenario of a bare name
    (``resolve_scenario``).

    Args:
        overrides: ``KEY=VALUE`` strings (``--set``), applied in order.
        given_as: The option that gave an override, for errors (``{"seed=3": "--seed"}``);
            others are named ``--set KEY``.
    """
    path = resolve_scenario(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8-sig"))  # a leading BOM is fine
    except FileNotFoundError:
        raise ScenarioError(f"{path}: file not found") from None
    except IsADirectoryError:
        raise ScenarioError(f"{path}: is a directory, expected a TOML scenario file") from None
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{path}: not valid TOML: {exc}") from None
    except UnicodeDecodeError as exc:
        raise ScenarioError(
            f"{path}: not UTF-8 text (byte 0x{exc.object[exc.start]:02x} at offset {exc.start}); "
            "save it as UTF-8"
        ) from None
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    data = apply_overrides(data, overrides or [])
    overridden = {}
    for text in overrides or []:
        key = ".".join(parse_override(text)[0])
        overridden[key] = (given_as or {}).get(text, f"--set {key}")
    scenario = scenario_from_dict(data, str(path), overridden)
    scenario.cells(str(path))  # every sweep cell is valid before any work starts
    return scenario
