"""The missing-beam regressor of the paper (``../shared/docs/method.md``), with a heteroscedastic sigma head.

Inputs for one ping: ``X`` the N past full beam vectors (N, 4), ``P`` the beams measured now, ``M`` the mean
of ``X`` over time. All in m/s; the model normalises them internally with per-beam statistics of the
training beams, stored as buffers so that they travel with the weights.
"""
from __future__ import annotations

import torch
from torch import nn

from graphnav.core.errors import ConfigError
from graphnav.core.scenarios import SCENARIOS

#: Past window length N of the paper for each number of missing beams.
DEFAULT_N_PAST = {1: 3, 2: 3, 3: 5}


#: Why no beam-only network serves a ping without a measured beam (training or loading one is refused with it).
NO_BEAM_ONLY_TOTAL_OUTAGE = ("a beam-only network needs a measured beam: a ping without one is completed by the "
                             "average estimator (graphnav.nets.AverageCompleter)")


def normalize_missing(missing) -> tuple[int, ...]:
    """Missing beams as a sorted tuple of 0-based indices from a scenario name or indices."""
    if isinstance(missing, str):
        if missing not in SCENARIOS or not SCENARIOS[missing]:
            names = sorted(k for k, v in SCENARIOS.items() if v)
            raise ConfigError(f"unknown missing-beam scenario '{missing}'; choose one of {names} "
                              "or give 0-based beam indices")
        return tuple(SCENARIOS[missing])
    out = tuple(sorted({int(b) for b in missing}))
    if not 1 <= len(out) <= 4 or any(b not in range(4) for b in out):
        raise ConfigError(f"missing beams must be 1 to 4 distinct 0-based indices in 0..3, got {missing}")
    return out


def scenario_name(missing) -> str:
    """``2-missing``/``3-missing`` for the presets, else ``missing-<indices>`` (0-based)."""
    missing = normalize_missing(missing)
    for name, preset in SCENARIOS.items():
        if preset == missing:
            return name
    return "missing-" + "-".join(map(str, missing))


class BeamRegressor(nn.Module):
    """Regress the missing beams of one ping from the past beams and the beams measured now.

    Architecture (method.md): ``Z = tanh(Conv1d(X))`` with the N past samples as input channels, 2N output
    channels, kernel 2, stride 2 over the 4-beam axis (4N features); residual ``Y = flatten(Z) + flatten(X)``;
    ``L = ReLU(W2 ReLU(W1 Y + b1) + b2)``; ``U = concat(L, P, M)``; ``O = W3 U + b3``. Sizes for the paper's
    cases: 2 missing, N = 3: conv 3->6 (12 features), FC 12->16, 16->2, final 8->2; 3 missing, N = 5:
    conv 5->10 (20), FC 20->16, 16->3, final 8->3.

    The output layer is linear, not ReLU as printed in the paper: beam velocities are signed (the aft
    beams are negative whenever the vehicle moves forward), and a ReLU output could never predict them.

    Uncertainty: a separate head ``s = softplus(W5 tanh(W4 concat(Y, P, M) + b4) + b5)`` gives a per-beam
    sigma, trained after the mean network with the Gaussian negative log-likelihood while the mean network
    is frozen, so the regressed beams are exactly those of the paper's network.

    Args:
        missing: scenario name or 0-based indices of the missing beams.
        n_past: past window N (default 3 for 1-2 missing beams, 5 for 3).
        hidden: width of the hidden FC layer (16 in the paper).
        sigma_hidden: width of the sigma head's hidden layer.
        residual: regress the change of each missing beam from its mean over the past window (the average
            estimator's prediction) instead of its value; the output layer starts at zero, so an untrained
            network is the average estimator and training departs from it only where that lowers the loss.
    """

    def __init__(self, missing=(0, 2), n_past: int | None = None, hidden: int = 16, sigma_hidden: int = 16,
                 residual: bool = False):
        super().__init__()
        self.missing = normalize_missing(missing)
        if len(self.missing) == 4:
            raise ConfigError(NO_BEAM_ONLY_TOTAL_OUTAGE)
        self.kept = tuple(b for b in range(4) if b not in self.missing)
        self.n_past = int(n_past or DEFAULT_N_PAST[len(self.missing)])
        if self.n_past < 1:
            raise ConfigError(f"n_past must be >= 1, got {n_past}")
        n_miss, n_kept, n_feat = len(self.missing), len(self.kept), 4 * self.n_past
        self.hidden, self.sigma_hidden, self.residual = hidden, sigma_hidden, bool(residual)
        self.conv = nn.Conv1d(self.n_past, 2 * self.n_past, kernel_size=2, stride=2)
        self.fc1 = nn.Linear(n_feat, hidden)
        self.fc2 = nn.Linear(hidden, n_miss)
        self.out = nn.Linear(n_miss + n_kept + 4, n_miss)
        self.sigma_head = nn.Sequential(nn.Linear(n_feat + n_kept + 4, sigma_hidden), nn.Tanh(),
                                        nn.Linear(sigma_hidden, n_miss))
        # Per-beam input normalisation (m/s), set from the training beams by set_normalisation().
        self.register_buffer("beam_mean", torch.zeros(4))
        self.register_buffer("beam_std", torch.ones(4))
        self.register_buffer("sigma_floor", torch.tensor(1e-3))   # m/s, keeps the NLL finite
        if self.residual:
            nn.init.zeros_(self.out.weight)
            nn.init.zeros_(self.out.bias)

    def set_normalisation(self, beams: torch.Tensor) -> None:
        """Per-beam mean and std of the training beams (S, 4), m/s."""
        beams = torch.as_tensor(beams, dtype=self.beam_mean.dtype)
        self.beam_mean.copy_(beams.mean(0))
        self.beam_std.copy_(beams.std(0).clamp_min(1e-3))

    def features(self, past: torch.Tensor, measured: torch.Tensor):
        """Normalised residual features ``Y`` (B, 4N), ``P`` (B, n_kept) and ``M`` (B, 4)."""
        x = (past - self.beam_mean) / self.beam_std                       # (B, N, 4)
        p = (measured - self.beam_mean[list(self.kept)]) / self.beam_std[list(self.kept)]
        z = torch.tanh(self.conv(x))                                       # (B, 2N, 2)
        y = z.flatten(1) + x.flatten(1)                                    # residual path, 4N features
        return y, p, x.mean(1)

    def forward(self, past: torch.Tensor, measured: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Missing beams and their sigma.

        Args:
            past: (B, N, 4) past full beam vectors, oldest first, m/s.
            measured: (B, n_kept) the beams measured now, in beam order of ``kept``, m/s.

        Returns:
            (beams (B, n_missing), sigma (B, n_missing)), m/s, in the beam order of ``missing``.
        """
        y, p, m = self.features(past, measured)
        hidden = torch.relu(self.fc2(torch.relu(self.fc1(y))))
        out = self.out(torch.cat([hidden, p, m], dim=1))
        raw_sigma = self.sigma_head(torch.cat([y, p, m], dim=1))
        scale = self.beam_std[list(self.missing)]
        base = past.mean(1)[:, list(self.missing)] if self.residual else self.beam_mean[list(self.missing)]
        beams = out * scale + base
        sigma = nn.functional.softplus(raw_sigma) * scale + self.sigma_floor
        return beams, sigma

    def mean_parameters(self):
        """Parameters of the paper's network (everything except the sigma head)."""
        return [p for name, p in self.named_parameters() if not name.startswith("sigma_head.")]

    def architecture(self) -> dict:
        """Constructor arguments, for the model card."""
        arch = {"missing": list(self.missing), "n_past": self.n_past, "hidden": self.hidden,
                "sigma_hidden": self.sigma_hidden}
        if self.residual:       # absent in the cards of networks that predict values
            arch["residual"] = True
        return arch


class BeamEnsemble(nn.Module):
    """A deep ensemble of :class:`BeamRegressor` networks trained alike from different seeds.

    The completion is the members' mean; its variance is the members' mean variance plus the spread of their
    means (the mixture's variance), so disagreement between members widens the sigma where the training data
    did not pin the answer down. Same interface as one network (``missing``, ``kept``, ``n_past``,
    ``forward``, ``architecture``), so completers, evaluation and model cards take either.

    Args:
        members: number of networks (>= 2).
        member_arch: :meth:`BeamRegressor.architecture` of each (they share it).
    """

    def __init__(self, members: int = 2, **member_arch):
        super().__init__()
        if int(members) < 2:
            raise ConfigError(f"an ensemble needs at least 2 members, got {members}")
        self.members = nn.ModuleList(BeamRegressor(**member_arch) for _ in range(int(members)))
        first = self.members[0]
        self.missing, self.kept, self.n_past = first.missing, first.kept, first.n_past

    @classmethod
    def of(cls, networks: list[BeamRegressor]) -> "BeamEnsemble":
        """The ensemble of trained ``networks`` (same architecture; each keeps its own input normalisation)."""
        ens = cls(len(networks), **networks[0].architecture())
        for member, net in zip(ens.members, networks):
            if net.architecture() != networks[0].architecture():
                raise ConfigError("ensemble members differ in architecture")
            member.load_state_dict(net.state_dict())
        return ens.eval()

    @property
    def beam_mean(self) -> torch.Tensor:
        """Input normalisation (m/s) of member 0, what the model card records. Each member normalises with its
        own (from its own augmented copies; they differ by about 0.02 m/s) inside its ``forward``."""
        return self.members[0].beam_mean

    @property
    def beam_std(self) -> torch.Tensor:
        return self.members[0].beam_std

    def forward(self, past: torch.Tensor, measured: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Missing beams (the members' mean) and sigma (``sqrt(mean sigma_i^2 + var mu_i)``), m/s, as
        :meth:`BeamRegressor.forward`."""
        outs = [m(past, measured) for m in self.members]
        mu = torch.stack([o[0] for o in outs])
        var = torch.stack([o[1] ** 2 for o in outs]).mean(0) + mu.var(0, unbiased=False)
        return mu.mean(0), var.sqrt()

    def architecture(self) -> dict:
        """Constructor arguments, for the model card: the members' architecture and their number."""
        return {**self.members[0].architecture(), "members": len(self.members)}


def beam_model(**architecture) -> nn.Module:
    """The beam-only model a card's ``architecture`` describes: a :class:`BeamEnsemble` when it has
    ``members``, else one :class:`BeamRegressor`."""
    if "members" in architecture:
        return BeamEnsemble(**architecture)
    return BeamRegressor(**architecture)
