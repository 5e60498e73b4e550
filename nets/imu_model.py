"""The IMU-aware missing-beam regressor: past beams, beams measured now, and the preintegrated IMU window.

As LiBeamsNet (Cohen & Klein), the network sees the inertial readings next to the beams; unlike it, the
IMU window is first preintegrated (:mod:`graphnav.nets.imu_window`) so that a small network on a CPU can use
it: every past beam vector is propagated to the ping with the IMU (a physical prior), and a small MLP
corrects that prior from everything it sees.

For one ping, with ``T`` the (4, 3) beam matrix and ``T+`` its pseudo-inverse (the DVL the beams were made with:
the default :class:`~graphnav.core.config.DvlSpec`, the Snapir's, unless trained for another DVL):

1. ``v_j = T+ b_j`` the least-squares velocity of past ping j (N full past beam vectors, oldest first);
2. gravity in the body frame now, ``g_now = M v_{N} - f_mean`` (window mean of the rotated specific force,
   corrected by the mean centripetal term of a vehicle holding its last body velocity);
3. ``v_now|j = C_j_now v_j + tail_j + g_now tau_j`` (``tau_j`` the time from ping j to now) and its beams
   ``p_j = T v_now|j``;
4. prior ``p = a * sum_j w_j p_j + (1 - a) * sum_j u_j b_j`` (learned softmax weights ``w``, ``u`` over the
   lags), missing entries only: a blend of the IMU-propagated beams and the held past beams (what the average
   estimator does), with ``a = sigmoid(G(h))`` per missing beam an input-dependent output of the network
   (``G`` linear). Trained through recursive outages (:mod:`graphnav.nets.imu_training`), the blend lets the
   network fall back to holding the velocity where the propagated prior would drift (a tilt error of 0.1 deg
   is 0.017 m/s^2 integrated through a 30-ping outage);
5. output ``p + std * (MLP(h) + L(h))`` with ``h`` the normalised past beams, propagated beams, measured
   beams, mean angular rates and gravity direction (MLP: two tanh layers; L: a linear path). The shipped
   networks use ``relative`` inputs (the beams minus the prior, so that an offset fed back along the
   unobserved direction cannot change the correction) and a correction that does not see the rates and the
   gravity direction (``correction_sees_imu=False``: an attitude-dependent offset of a few mm/s per ping
   becomes a drift of 0.1-0.5 m/s through a 30-ping outage on a steady leg); the gate and the sigma head see
   everything, and the IMU enters the mean through the propagated prior;
6. a sigma head ``softplus(W2 tanh(W1 h)) * std * gain + floor``, trained afterwards with the Gaussian NLL
   while the mean network is frozen; ``gain`` is set so that the RMS of error/sigma is 1 on held-out pings.

All inputs in SI units (m/s, m/s^2, rad/s), body frame (FRD).
"""
from __future__ import annotations

import torch
from torch import nn

from graphnav.core.config import DvlSpec
from graphnav.core.dvl import DvlGeometry
from graphnav.core.errors import ConfigError

from .imu_window import IMU_RATE_HZ, IMU_WINDOW_S, N_SUMMARY
from .model import normalize_missing

#: Past window N of the IMU-aware networks by number of missing beams (pings). Chosen between 3 and 5 on the
#: validation trajectories (2 missing: per-ping velocity RMSE 16.8 % below the average with N = 5, 15.2 %
#: with N = 3; 3 missing passes with N = 3 by a wide margin), so those numbers are mildly optimistic. The
#: total-outage network (4 missing) takes the 3-missing N without a choice of its own.
DEFAULT_IMU_N_PAST = {1: 3, 2: 5, 3: 3, 4: 3}


class ImuBeamRegressor(nn.Module):
    """Regress the missing beams of one ping from the past beams, the measured beams and the IMU.

    Args:
        missing: scenario name or 0-based indices of the missing beams.
        n_past: past window N (pings); default :data:`DEFAULT_IMU_N_PAST`.
        hidden: width of the MLP's two hidden layers.
        sigma_hidden: width of the sigma head's hidden layer.
        ping_dt: DVL ping period, s (the past pings are this far apart).
        imu_window_s: length of the IMU window, s.
        imu_rate_hz: IMU rate, Hz.
        blend: learn the blend between the IMU-propagated and the held prior (False: propagated prior only).
        relative: the heads see the beams relative to the prior (past, propagated and measured beams minus
            the prior of all four beams), not their values, so a velocity offset common to the past and the
            measured beams (an error fed back along the unobserved direction) does not change the correction,
            and the correction cannot learn a velocity-dependent bias that compounds through an outage.
        correction_sees_imu: the correction (MLP and linear path) also sees the angular-rate summary and the
            gravity direction. False: only the blend gate and the sigma head see them, so on a steady leg the
            correction has no attitude-dependent offset to add at every ping (0.005 m/s per ping is 0.15 m/s
            after a 30-ping outage); the IMU still enters the mean through the propagated prior.
            (Shipped: False.)
        T_b: (4, 3) unit vectors of the beams, body frame, of the DVL the beams come from (default: the
            :class:`~graphnav.core.config.DvlSpec` default, the Snapir's); a buffer, so the weights carry it.
    """

    def __init__(self, missing=(0, 2), n_past: int | None = None, hidden: int = 32, sigma_hidden: int = 16,
                 ping_dt: float = 1.0, imu_window_s: float = IMU_WINDOW_S, imu_rate_hz: float = IMU_RATE_HZ,
                 blend: bool = False, relative: bool = False, correction_sees_imu: bool = True, T_b=None):
        super().__init__()
        self.missing = normalize_missing(missing)
        self.kept = tuple(b for b in range(4) if b not in self.missing)
        n_past = DEFAULT_IMU_N_PAST[len(self.missing)] if n_past is None else n_past
        if n_past < 1:
            raise ConfigError(f"n_past must be >= 1, got {n_past}")
        if imu_window_s < n_past * ping_dt:
            raise ConfigError(f"imu_window_s={imu_window_s} must cover the {n_past} past pings "
                              f"({n_past * ping_dt} s)")
        self.n_past, self.hidden, self.sigma_hidden = int(n_past), hidden, sigma_hidden
        self.ping_dt, self.imu_window_s, self.imu_rate_hz = float(ping_dt), float(imu_window_s), float(imu_rate_hz)
        n_miss, n_kept, n_aux = len(self.missing), len(self.kept), N_SUMMARY + 3
        n_in = 8 * self.n_past + n_kept + n_aux
        self.blend, self.relative = bool(blend), bool(relative)
        self.correction_sees_imu = bool(correction_sees_imu)
        n_corr = n_in if self.correction_sees_imu else n_in - n_aux
        self.lag_logits = nn.Parameter(torch.zeros(self.n_past))
        if self.blend:
            self.hold_logits = nn.Parameter(torch.zeros(self.n_past))
            self.gate = nn.Linear(n_in, n_miss)
            nn.init.zeros_(self.gate.weight)
            nn.init.constant_(self.gate.bias, 3.0)      # a = 0.95: start near the propagated prior
        self.mlp = nn.Sequential(nn.Linear(n_corr, hidden), nn.Tanh(), nn.Linear(hidden, hidden), nn.Tanh(),
                                 nn.Linear(hidden, n_miss))
        self.linear = nn.Linear(n_corr, n_miss)
        for layer in (self.mlp[-1], self.linear):     # start from the IMU-propagated prior
            nn.init.zeros_(layer.weight)
            nn.init.zeros_(layer.bias)
        self.sigma_head = nn.Sequential(nn.Linear(n_in, sigma_hidden), nn.Tanh(), nn.Linear(sigma_hidden, n_miss))
        T_b = torch.as_tensor(DvlGeometry.from_spec(DvlSpec()).T_b if T_b is None else T_b, dtype=torch.float32)
        if T_b.shape != (4, 3):
            raise ConfigError(f"T_b must be the (4, 3) beam unit vectors, got shape {tuple(T_b.shape)}")
        self.register_buffer("T_b", T_b)
        self.register_buffer("T_pinv", torch.linalg.pinv(T_b))
        self.register_buffer("tau", torch.arange(self.n_past, 0, -1, dtype=torch.float32) * self.ping_dt)
        self.register_buffer("beam_mean", torch.zeros(4))
        self.register_buffer("beam_std", torch.ones(4))
        self.register_buffer("aux_mean", torch.zeros(n_aux))
        self.register_buffer("aux_std", torch.ones(n_aux))
        if self.relative:       # normalisation of the relative inputs
            self.register_buffer("h_mean", torch.zeros(n_in))
            self.register_buffer("h_std", torch.ones(n_in))
        self.register_buffer("sigma_gain", torch.tensor(1.0))
        self.register_buffer("sigma_floor", torch.tensor(1e-3))   # m/s, keeps the NLL finite

    @property
    def imu_samples(self) -> int:
        """Number of IMU samples of the window the network expects."""
        return int(round(self.imu_window_s * self.imu_rate_hz))

    def propagate(self, past, rot, tail, f_mean, M):
        """Past beams propagated to the ping (B, N, 4), m/s, and the gravity direction now (B, 3)."""
        v = past @ self.T_pinv.T                                           # (B, N, 3)
        g_now = (M @ v[:, -1, :, None])[..., 0] - f_mean                   # (B, 3)
        v_now = (rot @ v[..., None])[..., 0] + tail + g_now[:, None, :] * self.tau[None, :, None]
        g_dir = g_now / g_now.norm(dim=1, keepdim=True).clamp_min(1e-6)
        return v_now @ self.T_b.T, g_dir

    def _aux(self, summary, g_dir):
        return torch.cat([summary, g_dir], dim=1)

    def set_normalisation(self, beams, summary, g_dir) -> None:
        """Per-feature mean and std from the training beams (S, 4), summaries (S, 6) and gravity directions."""
        beams = torch.as_tensor(beams, dtype=torch.float32)
        self.beam_mean.copy_(beams.mean(0))
        self.beam_std.copy_(beams.std(0).clamp_min(1e-3))
        aux = self._aux(torch.as_tensor(summary, dtype=torch.float32), torch.as_tensor(g_dir, dtype=torch.float32))
        self.aux_mean.copy_(aux.mean(0))
        self.aux_std.copy_(aux.std(0).clamp_min(1e-4))

    def set_input_normalisation(self, past, measured, rot, tail, f_mean, M, summary) -> None:
        """With ``relative``: mean and std of the relative inputs on the training samples (after
        :meth:`set_normalisation`)."""
        if not self.relative:
            return
        self.h_mean.zero_()
        self.h_std.fill_(1.0)
        with torch.no_grad():
            _, h = self.features(past, measured, rot, tail, f_mean, M, summary)
        n = h.shape[1] - self.aux_mean.numel()
        self.h_mean[:n].copy_(h[:, :n].mean(0))
        self.h_std[:n].copy_(h[:, :n].std(0).clamp_min(1e-4))

    def features(self, past, measured, rot, tail, f_mean, M, summary):
        """Prior for the missing beams (B, n_missing), m/s, and the normalised input ``h`` of the heads."""
        prop, g_dir = self.propagate(past, rot, tail, f_mean, M)
        w = torch.softmax(self.lag_logits, 0)
        miss, kept = list(self.missing), list(self.kept)
        prior = (prop * w[None, :, None]).sum(1)                           # (B, 4)
        held = (past * torch.softmax(self.hold_logits, 0)[None, :, None]).sum(1) if self.blend else prior
        aux = (self._aux(summary, g_dir) - self.aux_mean) / self.aux_std
        if self.relative:
            ref = 0.5 * (prior + held)      # the gate's inputs must not depend on the gate
            h = torch.cat([(past - ref[:, None]).flatten(1), (prop - ref[:, None]).flatten(1),
                           measured - ref[:, kept]], dim=1)
            h = torch.cat([(h - self.h_mean[:h.shape[1]]) / self.h_std[:h.shape[1]], aux], dim=1)
        else:
            x = ((past - self.beam_mean) / self.beam_std).flatten(1)
            xp = ((prop - self.beam_mean) / self.beam_std).flatten(1)
            p = (measured - self.beam_mean[kept]) / self.beam_std[kept]
            h = torch.cat([x, xp, p, aux], dim=1)
        prior, held = prior[:, miss], held[:, miss]
        if self.blend:
            a = torch.sigmoid(self.gate(h))
            prior = a * prior + (1.0 - a) * held
        return prior, h

    def forward(self, past, measured, rot, tail, f_mean, M, summary):
        """Missing beams and their sigma.

        Args:
            past: (B, N, 4) past full beam vectors, oldest first, m/s.
            measured: (B, n_kept) beams measured now, beam order of ``kept``, m/s.
            rot, tail, f_mean, M, summary: the :class:`~graphnav.nets.imu_window.ImuFeatures` fields.

        Returns:
            (beams (B, n_missing), sigma (B, n_missing)), m/s, beam order of ``missing``.
        """
        prior, h = self.features(past, measured, rot, tail, f_mean, M, summary)
        scale = self.beam_std[list(self.missing)]
        hc = h if self.correction_sees_imu else h[:, :self.linear.in_features]     # aux columns are last
        beams = prior + scale * (self.mlp(hc) + self.linear(hc))
        sigma = nn.functional.softplus(self.sigma_head(h)) * scale * self.sigma_gain + self.sigma_floor
        return beams, sigma

    def mean_parameters(self):
        """Parameters of the mean network (everything except the sigma head)."""
        return [p for name, p in self.named_parameters() if not name.startswith("sigma_head.")]

    def architecture(self) -> dict:
        """Constructor arguments, for the model card."""
        return {"missing": list(self.missing), "n_past": self.n_past, "hidden": self.hidden,
                "sigma_hidden": self.sigma_hidden, "ping_dt": self.ping_dt, "imu_window_s": self.imu_window_s,
                "imu_rate_hz": self.imu_rate_hz, "blend": self.blend, "relative": self.relative,
                "correction_sees_imu": self.correction_sees_imu}
