"""Calibrate model parameters on measurements: ``calibrate(model, experiments, parameters)``.

Least squares (``scipy.optimize.least_squares``, trust-region reflective,
bounded) on residuals normalised per signal: each residual is divided by the
white-noise level of its measured signal (estimated from the measurement,
:func:`pneucore.analysis.metrics.noise_sigma`), so pressures and positions weigh by
their information, jointly over all experiments. The Jacobian is computed
by finite differences with the columns simulated in parallel threads (the
compiled core releases the GIL).

Statistics follow the Gaussian likelihood with one unknown variance per
experiment and signal, concentrated out: ``-2 ln L = sum N_s ln(RSS_s / N_s)``
(+ const). Standard errors and correlations come from the Jacobian at the
optimum (``cov = (J^T J)^-1`` with residuals scaled by their fitted RMS, as
lmfit does); AIC = -2 ln L + 2k, BIC = -2 ln L + k ln N. Residuals of a
dynamic model are rarely white: each series is also scaled by the square
root of its integrated autocorrelation time ``tau``
(:mod:`pneucore.analysis.autocorrelation`), so that ``n`` correlated samples count as
``n / tau`` independent ones in the covariance (a quasi-likelihood
correction; exact for AR(1) noise when the sensitivities vary slowly). With
white residuals ``tau = 1`` and the usual standard errors result. Not
included: the error of initial pressures estimated from the measurement's
first samples (:class:`pneucore.data.experiment.Experiment`), which correlated
noise does not average out; give them in the experiment's scenario when the
noise is strongly correlated.
"""
from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

from pneucore.analysis.autocorrelation import residual_times, times_report
from pneucore.analysis.compare import plain_json, replay, summarise
from pneucore.data.experiment import as_experiments
from pneucore.data.measurement import ACCURACY, sensor_zero
from pneucore.analysis.metrics import noise_sigma
from pneucore.description.model import Model
from pneucore.description.paths import parse_parameters, set_values
from pneucore.progress import Cancelled
from pneucore.analysis.blas_threads import single_threaded_blas
from pneucore.analysis.records import Records

#: Worker threads for the finite-difference Jacobian (the machine has 2 cores)
THREADS = 2
#: Smallest noise level assumed per signal (SI): a signal recorded exactly constant (a locked
#: position, noise-free synthetic data) must not get an infinite weight
SIGMA_FLOOR = {"p_a": 1.0, "p_b": 1.0, "x": 1e-7, "v": 1e-6, "T_a": 1e-3, "T_b": 1e-3}
#: Replay sets an objective keeps of its last evaluations (the end point is simulated again
#: to reweigh and to summarise it): each holds the records' simulated series
RECENT_REPLAYS = 2
#: Residual given to samples a failed simulation never reached (keeps the cost finite)
FAILED_RESIDUAL = 1e3
#: Simulated time over all experiments [s] beyond which a fit first runs on the records' first
#: seconds (:func:`window`, this much in all) and then goes on from that point on the full
#: records: the optimiser's iterations far from the optimum cost a short replay, and only
#: the last few, near it, a full one. The diagnosis's usual tests (two 1 s records, the
#: confusion set's at most 2 s in all) stay below it and are fitted exactly as before
PREFIT_SECONDS = 4.0
#: Residual evaluations of each pass on the full records after the window's fit [-]: the
#: first differenced Jacobian gives a Gauss-Newton step from near the optimum, and the
#: Broyden updates a few more, one replay each
POLISH_NFEV = 4

#: Sensor parameters a fit may hold beside the model's: ``sensors.<signal>.offset`` (added to
#: what the sensor reads, in the signal's SI unit) and ``sensors.<signal>.gain`` (relative error
#: of its gain [-], about ambient pressure for a pressure: a gauge sensor's span). They belong
#: to the rig's sensors, not to the model: a fit applies them to the simulated signal, as the
#: sensor would to the true one (``read = zero + (1 + gain) (true - zero) + offset``)
SENSOR_PREFIX = "sensors."
#: The fields of a sensor parameter, with their default half-range as a share of the signal's
#: measured span (offset) or as a relative error (gain)
SENSOR_FIELDS = {"offset": 0.2, "gain": 0.2}


def sensor_path(path):
    """``(signal, field)`` of a sensor parameter path ``sensors.x.offset``, or None."""
    if not isinstance(path, str) or not path.startswith(SENSOR_PREFIX):
        return None
    parts = path.split(".")
    if len(parts) != 3 or parts[2] not in SENSOR_FIELDS:
        return None
    return parts[1], parts[2]


def _sensed(e, sensors, ambient, stroke):
    """``e`` with the initial state its record gives read through corrected sensors: the first
    samples of a sensor with an offset or a gain error start the model where the true signal
    was (a position zero of 3 mm starts the piston 3 mm lower), not where the sensor read."""
    from pneucore.data.experiment import Experiment
    scen = dict(e.scenario)
    ini = dict(scen.get("initial") or {})
    changed = False
    for sig, sv in sensors.items():
        zero = sensor_zero(sig, ambient)
        given = scen.get("x0") if sig == "x" else ini.get(sig)
        if given is not None or sig not in ("x", "p_a", "p_b", "T_a", "T_b"):
            continue
        first = e._first(sig)
        if first is None:
            continue
        true = zero + (first - sv.get("offset", 0.0) - zero) / (1.0 + sv.get("gain", 0.0))
        if sig == "x":
            scen["x0"] = min(max(true, 0.0), stroke)
        elif true > 0:
            ini[sig] = true
        changed = True
    if not changed:
        return e
    if ini:
        scen["initial"] = ini
    return Experiment(e.measurement, scen, e.name, e.load_force, e.supply_pressure, e.dataset_id,
                      e.time_offset)


def sensor_specs(experiments, signals, fields=("offset", "gain"), parameters=None):
    """Specs of sensor parameters (:data:`SENSOR_PREFIX`) for ``signals``, starting at 0.

    Parameters
    ----------
    experiments : list of Experiment
        The experiments (their measured spans set the offsets' default bounds)
    signals : iterable of str
        Signals whose sensors are fitted
    fields : iterable of str
        ``offset`` and / or ``gain``
    parameters : dict or None
        ``{path: {"min", "max", "value"?, "vary"?}}`` overriding the defaults

    Returns
    -------
    specs : list of ParameterSpec
        Offsets in the signal's SI unit, gains relative [-]
    """
    from pneucore.data.measurement import SIGNAL_UNITS
    from pneucore.description.paths import ParameterSpec
    from pneucore.description.validation import FieldError, number
    out = []
    parameters = parameters or {}
    for sig in signals:
        span = max((float(np.nanmax(e.measurement.signals[sig]) - np.nanmin(e.measurement.signals[sig]))
                    for e in experiments if sig in e.measurement.signals), default=0.0)
        for f in fields:
            path = f"{SENSOR_PREFIX}{sig}.{f}"
            half = SENSOR_FIELDS[f] * (span if f == "offset" else 1.0) or 1.0
            opts = parameters.get(path) or {}
            lo = number(opts.get("min", -half), f"parameters.{path}.min")
            hi = number(opts.get("max", half), f"parameters.{path}.max")
            v = number(opts.get("value", 0.0), f"parameters.{path}.value")
            if not lo <= v <= hi or not lo < hi:
                raise FieldError(f"parameters.{path}", f"bounds [{lo:g}, {hi:g}] must hold the "
                                                       f"starting value {v:g}")
            out.append(ParameterSpec(path, v, lo, hi, bool(opts.get("vary", True)),
                                     SIGNAL_UNITS[sig] if f == "offset" else "-"))
    return out


def signal_sigmas(experiment):
    """Standard deviation of each fitted signal's error, by which its residual is divided.

    The sensor accuracy stated in the measurement's metadata (``meta["accuracy"]``,
    :func:`pneucore.data.measurement.sensor_accuracy`, SI) where given; otherwise the
    record's own noise (:func:`pneucore.analysis.metrics.noise_sigma`), at least 1e-6 of the
    signal's largest magnitude and :data:`SIGMA_FLOOR`, so that no signal can take all the
    weight by looking noise-free (issue 22, item 6).

    Parameters
    ----------
    experiment : Experiment
        The experiment whose signals are fitted [-]

    Returns
    -------
    sigma : dict
        ``{signal: sigma [SI unit of the signal]}`` [-]
    """
    sig = experiment.measurement.signals
    stated = experiment.measurement.meta.get(ACCURACY) or {}
    out = {}
    for s in experiment.signals:
        given = stated.get(s)
        if given is not None and math.isfinite(float(given)) and float(given) > 0:
            out[s] = float(given)
        else:
            out[s] = max(experiment.noise(s), 1e-6 * np.nanmax(np.abs(sig[s])),
                         SIGMA_FLOOR.get(s, 1e-12))
    return out


class Objective:
    """Weighted residuals of a set of experiments as a function of parameter values.

    ``check()`` (if given) is called before every set of simulations; it may raise
    :class:`pneucore.progress.Cancelled` to stop the fit.

    ``prior`` (``{path: (centre, sigma)}``, SI) adds one residual row
    ``(value - centre) / sigma`` per varied parameter it names: a Gaussian prior
    centred on the user's (catalogue) value, so that a direction the data do not
    resolve stays where the user put it (the least change) while a direction the
    data resolve is set by the data (thousands of samples against one row).
    """

    def __init__(self, model, experiments, specs, check=None, prior=None):
        self.check = check
        self.model = model
        self.experiments = experiments
        self.specs = [s for s in specs if s.vary]
        self.fixed = {s.path: s.value for s in specs if not s.vary}
        # the records' weights, prepared once (:class:`pneucore.analysis.records.Records`),
        # copied: a fit reweights its own
        self.sigma = ([dict(d) for d in experiments.sigma] if isinstance(experiments, Records)
                      else [signal_sigmas(e) for e in experiments])
        self.n_eval = 0
        self.best = (np.inf, None)
        #: the best cost after each evaluation of the residuals (:meth:`residuals`) [-]
        self.trace = []
        self._finite_cache = {}
        self._recent = []
        prior = prior or {}
        idx = [(i, prior[s.path]) for i, s in enumerate(self.specs) if s.path in prior]
        self._prior_idx = np.array([i for i, _ in idx], int)
        self._prior_c = np.array([c for _, (c, _) in idx], float)
        self._prior_s = np.array([sg for _, (_, sg) in idx], float)

    def prior_rows(self, theta):
        """Residual rows of the prior at ``theta`` (empty without a prior)."""
        if not self._prior_idx.size:
            return np.empty(0)
        return (np.asarray(theta, float)[self._prior_idx] - self._prior_c) / self._prior_s

    def prior_jacobian(self, scales):
        """d(prior rows)/dz for scaled parameters ``z = theta / scales``: ``(n_prior, n)``."""
        J = np.zeros((self._prior_idx.size, len(self.specs)))
        J[np.arange(self._prior_idx.size), self._prior_idx] = \
            np.asarray(scales, float)[self._prior_idx] / self._prior_s
        return J

    def full(self, replays, theta):
        """Weighted data residuals followed by the prior's rows: what the optimiser minimises."""
        return np.concatenate([self.weighted(replays), self.prior_rows(theta)])

    # parameter vector <-> model
    def values(self, theta):
        d = dict(self.fixed)
        d.update({s.path: float(v) for s, v in zip(self.specs, theta)})
        return d

    def model_at(self, theta):
        return set_values(self.model, {p: v for p, v in self.values(theta).items()
                                       if sensor_path(p) is None})

    def replays(self, theta):
        if self.check is not None:
            self.check()
        # the optimiser's end point, simulated once more to reweigh and to summarise it, is
        # usually one of its last evaluations: those are kept (the replays do not depend on
        # the weights), and a long record is not simulated twice at the same point
        key = np.asarray(theta, float).tobytes()
        for k, rps in list(self._recent):
            if k == key:
                return rps
        rps = self._replays(theta)
        self._recent = (self._recent + [(key, rps)])[-RECENT_REPLAYS:]
        return rps

    def _replays(self, theta):
        m = self.model_at(theta)
        sensors = {}
        for p, v in self.values(theta).items():
            sp = sensor_path(p)
            if sp is not None:
                sensors.setdefault(sp[0], {})[sp[1]] = v
        if not sensors:
            # the core's outputs freed at once: a fit reads the signals, a summary a few more;
            # a model the records were replayed on already is taken from their cache
            if isinstance(self.experiments, Records):
                return self.experiments.replayed(m)
            return [replay(m, e).drop_core_outputs() for e in self.experiments]
        amb = self.model.ambient.pressure
        rps = [replay(m, _sensed(e, sensors, amb, m.jack.stroke)) for e in self.experiments]
        if sensors:
            # what the rig's sensors would read of the simulated signals
            for rp in rps:
                for sig, sv in sensors.items():
                    if sig in rp.simulated:
                        zero = sensor_zero(sig, amb)
                        g = rp.simulated[sig]
                        rp.simulated[sig] = g + sv.get("offset", 0.0) + sv.get("gain", 0.0) * (g - zero)
        return [rp.drop_core_outputs() for rp in rps]

    def _finite(self, meas):
        """``(isfinite(meas), all finite)``, found once per measured series (an optimiser
        weighs the same records at every evaluation)."""
        hit = self._finite_cache.get(id(meas))
        if hit is None or hit[0] is not meas:
            ok = np.isfinite(meas)
            hit = self._finite_cache[id(meas)] = (meas, ok, bool(ok.all()))
        return hit[1], hit[2]

    def weighted(self, replays):
        parts = []
        for rp, sig in zip(replays, self.sigma):
            for s in rp.measured:
                meas = rp.experiment.measurement.signals[s]
                sim = rp.simulated[s]
                n = sim.shape[0]
                ok, whole = self._finite(meas)
                if whole and n == meas.shape[0] and np.isfinite(sim).all():
                    parts.append((sim - meas) / sig[s])   # every sample recorded and reached
                    continue
                r = np.zeros(meas.shape[0])
                ok_n = ok[:n] & np.isfinite(rp.simulated[s])
                r[:n][ok_n] = (rp.simulated[s][ok_n] - meas[:n][ok_n]) / sig[s]
                # samples the simulation did not reach (solver failure) get a large residual
                miss = ok.copy()
                miss[:n] = ok[:n] & ~np.isfinite(rp.simulated[s])
                r[miss] = FAILED_RESIDUAL
                parts.append(r[ok])
        return np.concatenate(parts)

    def residuals(self, theta):
        rps = self.replays(theta)
        r = self.full(rps, theta)
        self.n_eval += 1
        c = float(r @ r)
        if c < self.best[0]:
            self.best = (c, np.array(theta, float))
        self.trace.append(self.best[0])
        return r

    def rss(self, replays):
        """Per (experiment, signal) residual sum of squares and sample count."""
        out = []
        for rp in replays:
            for s in rp.measured:
                m, g = rp.measured[s], rp.simulated[s]
                ok = np.isfinite(m)
                gg = np.where(np.isfinite(g), g, m + FAILED_RESIDUAL * np.nanstd(m) + 1.0)
                out.append((rp.experiment.name, s, float(np.sum((gg[ok] - m[ok]) ** 2)), int(ok.sum())))
        return out


def neg2_loglik(rss_list):
    """Concentrated Gaussian ``-2 ln L`` with one variance per (experiment, signal)."""
    tot = 0.0
    n_all = 0
    for _, _, rss, n in rss_list:
        if n == 0:
            continue
        tot += n * math.log(max(rss, 1e-300) / n)
        n_all += n
    return tot + n_all * (1.0 + math.log(2.0 * math.pi))


def information_criteria(rss_list, k):
    """``(-2 ln L, AIC, BIC, N)`` for ``k`` fitted parameters (variances counted too)."""
    n_all = sum(n for *_, n in rss_list)
    k_tot = k + len(rss_list)
    m2ll = neg2_loglik(rss_list)
    return m2ll, m2ll + 2 * k_tot, m2ll + k_tot * math.log(max(n_all, 1)), n_all


def _scales(specs):
    out = []
    for s in specs:
        sc = abs(s.value)
        if sc == 0.0:
            sc = (s.max - s.min) / 100.0
        out.append(sc)
    return np.array(out, float)


def _duration(e):
    """Simulated length of an experiment's replay [s]."""
    t = e.times
    return float(min(t[-1], e.scenario.get("duration", np.inf))) if t.size else 0.0


def prefit_window(experiments, n_params):
    """The records' window (:func:`window`) that a fit of ``n_params`` parameters on them starts
    from, or None where it fits them whole: records within :data:`PREFIT_SECONDS`, nothing
    to fit, nothing that could be cut (too few samples in a window), or a window holding no more
    measured samples than parameters, too few to determine them (a held-out fold that marks
    the records' first seconds missing left it none, and the fit crashed).

    Parameters
    ----------
    experiments : list of Experiment
        Prepared experiments [-]
    n_params : int
        Parameters fitted [-]

    Returns
    -------
    window : list of Experiment or None
        The cut experiments, or None [-]
    """
    short = window(experiments) if n_params else None
    if short is None or not (sum(_duration(e) for e in short)
                             < sum(_duration(e) for e in experiments)):
        return None
    return short if _window_samples(short) > n_params else None


def _window_samples(experiments):
    """Finite samples of the compared signals the experiments hold [-]."""
    return sum(int(np.isfinite(e.measurement.signals[s]).sum()) for e in experiments
               for s in e.signals)


def window(experiments, seconds=None):
    """The experiments cut to their first seconds, ``seconds`` in all, or None when they are shorter.

    Each record keeps its start (initial state, first command) and the same cut
    ``d`` (water filling: a record shorter than ``d`` is kept whole, the others
    share the rest), so that every experiment still weighs in.

    Parameters
    ----------
    experiments : list of Experiment
        Prepared experiments [-]
    seconds : float or None
        Simulated time over all experiments to keep (None = :data:`PREFIT_SECONDS`, read when
        called) [s]

    Returns
    -------
    window : list of Experiment or None
        The cut experiments (None when the records hold no more than ``seconds``) [-]
    """
    seconds = PREFIT_SECONDS if seconds is None else seconds
    if isinstance(experiments, Records):   # cut once per length, held by the records
        return experiments.window(seconds)
    return cut_window(experiments, seconds)


def cut_window(experiments, seconds):
    """:func:`window` cut anew: the experiments to their first ``seconds`` in all [s], or None
    when they are shorter."""
    lengths = np.array([_duration(e) for e in experiments], float)
    if lengths.sum() <= seconds:
        return None
    order = np.sort(lengths)
    cut, left = seconds / len(order), seconds
    for i, d in enumerate(order):
        if d * (len(order) - i) >= left:
            cut = left / (len(order) - i)
            break
        left -= d
    out = []
    for e, d in zip(experiments, lengths):
        if d <= cut:
            out.append(e)
            continue
        try:
            out.append(e.cut(cut))
        except Exception:   # noqa: BLE001 - too few samples in the window: keep it whole
            out.append(e)
    return out


def _fd_jacobian(obj, theta, r0, scales, lo, hi, step=1e-3):
    """Forward differences in scaled units, columns simulated in parallel threads."""
    cols = []
    for j in range(len(theta)):
        h = step * scales[j]
        tj = theta.copy()
        if tj[j] + h > hi[j]:
            h = -h
        tj[j] += h
        cols.append((j, tj, h))

    def col(args):
        j, tj, h = args
        rps = obj.replays(tj)
        return j, (obj.full(rps, tj) - r0) / h

    J = np.empty((r0.shape[0], len(theta)))
    with ThreadPoolExecutor(THREADS) as pool:
        for j, c in pool.map(col, cols):
            J[:, j] = c
    return J


@dataclass
class Calibration:
    """Result of :func:`calibrate`; ``summary()`` is plain JSON."""
    model: Model
    values: dict
    correlations: dict
    error_before: object
    error_after: object
    aic: float
    bic: float
    neg2_loglik: float
    n_data: int
    n_params: int
    success: bool
    message: str
    nfev: int
    residual_times: list = field(default_factory=list, repr=False)
    rss_after: list = field(default_factory=list, repr=False)
    rss_before: list = field(default_factory=list, repr=False)
    aic_before: float = float("nan")
    bic_before: float = float("nan")
    #: the fit raised the overall error: the model as given was kept (:func:`kept_better`)
    kept_start: bool = False
    #: share of its residual energy the fit's last pass removed in the second half of its
    #: evaluations (:func:`tail_drop`) [-]: how much a fit its budget stopped was still gaining
    tail_drop: float = float("nan")
    #: the optimiser stopped at its budget of evaluations (``max_nfev``), not at a tolerance;
    #: a long record's polish, whose budget is its design, is not [-]
    out_of_budget: bool = False

    @property
    def autocorrelation_time(self):
        """``{"experiment/signal": tau}`` of the fitted residuals [samples]."""
        return times_report(self.residual_times)

    def summary(self):
        def errs(c):
            return {"errors": c.errors, "overall": c.overall, "phases": c.phases,
                    "piston_phases": c.piston_phases}
        return plain_json({
            "model": self.model.to_dict(), "values": self.values, "correlations": self.correlations,
            "error_before": errs(self.error_before), "error_after": errs(self.error_after),
            "aic": self.aic, "bic": self.bic, "aic_before": self.aic_before,
            "bic_before": self.bic_before, "neg2_loglik": self.neg2_loglik, "n_data": self.n_data,
            "n_params": self.n_params, "success": self.success, "message": self.message,
            "nfev": self.nfev, "autocorrelation_time": self.autocorrelation_time,
            "failure_windows_after": self.error_after.windows, "kept_start": self.kept_start,
        })


def window_fit(model, short, specs, max_nfev=40, progress=None, span=(0.0, 1.0), step="fitting",
               reweight=False, prior=None):
    """The fit on the records' first seconds (``short``: :func:`window` of them) that
    :func:`fit` starts the full records' fit from: the point reached, ``success``, ``message``
    and the window's residual energy (``rss_after``), no statistics."""
    return fit(model, short, specs, max_nfev=max_nfev, compute_before=False, progress=progress,
               span=span, step=step, reweight=reweight, prior=prior, statistics=False)


@single_threaded_blas
def fit(model, experiments, specs, max_nfev=40, compute_before=True, progress=None,
        span=(0.0, 1.0), step="fitting", reweight=False, prior=None, statistics=True,
        warm=False, prefit=None):
    """Fit ``specs`` on prepared experiments (shared by :func:`calibrate` and the diagnosis).

    ``progress(fraction, step)`` is reported within ``span`` as the optimiser's
    evaluations are used up; it may raise :class:`Cancelled` to stop.

    ``reweight``: after the first solution, each series (experiment, signal)
    is reweighted by the RMS of its own residual (never below its noise
    estimate) and the fit is continued: the optimum of the concentrated
    likelihood with one unknown variance per series, which the diagnosis's
    likelihood-ratio tests use. Without it the weights are the noise levels
    estimated from second differences, which coloured noise (a transducer
    filter) underestimates by different factors per signal: the fit then
    trades a large error on one signal for a small gain on another.

    ``prior``: ``{path: (centre, sigma)}`` (SI, see :class:`Objective`), a Gaussian
    prior on some of the varied parameters (maximum a posteriori instead of maximum
    likelihood). The reported statistics (RSS, likelihood, AIC/BIC, Eq. 25 errors) are
    the data's alone, and so are the standard errors and correlations: a parameter the data
    do not resolve keeps its large standard error (the confounding is reported), while its
    value stays at the prior's centre along the unresolved direction. ``stderr_prior`` is
    added beside each standard error: the posterior's, how well the value is known given the
    user's values along what the data do not resolve.

    Records longer than :data:`PREFIT_SECONDS` in all are first fitted on their first
    seconds (:func:`window`); the fit on the full records goes on from that point for
    :data:`POLISH_NFEV` evaluations a pass (a differenced Jacobian, then Broyden updates: one
    replay a step), so that a round costs a few replays of the full records whatever their
    length. The statistics (differenced afresh at the end point), the reference "before" and
    the guard against ending worse than the model as given are the full records' and the
    given model's. The window's fit computes no statistics of its own (``statistics=False``:
    only the point reached, ``success`` and ``message``, all the full fit reads of it).

    ``warm``: the starting values are already a fit's end point on these same records (a refit
    from it with a few parameters put back, say): on long records the window's fit is skipped
    and the polish starts there, since the window's own optimum lies farther from the full
    records' than the start does. Records within :data:`PREFIT_SECONDS` are fitted as usual.

    ``prefit``: the window's fit already made by the caller (:func:`window_fit` with these
    model, specs and options), used instead of making it again: the diagnosis fits a
    candidate's structural forms on the window, compares them there, and goes on with the
    better (:func:`pneucore.analysis.diagnosis.stages.joint_refit`); the result is the one
    this call would reach on its own.
    """
    def check():
        if progress is not None:
            frac = min(obj.n_eval / max(max_nfev, 1), 1.0)
            progress(span[0] + (span[1] - span[0]) * frac, step)

    obj = Objective(model, experiments, specs, check, prior)
    vs = obj.specs
    theta0 = np.array([s.value for s in vs], float)
    lo = np.array([s.min for s in vs], float)
    hi = np.array([s.max for s in vs], float)
    sc = _scales(vs)
    before = None
    rps0 = obj.replays(theta0)
    if compute_before:
        before = summarise(rps0)
    rss0 = obj.rss(rps0)
    success, message = True, "converged"
    out_of_budget = False   # stopped by max_nfev, not by a tolerance (the polish's budget aside)
    theta = theta0
    z_first = theta0 / sc
    short = prefit_window(experiments, len(vs))
    pre = None
    if short is not None and not warm:
        pre = prefit if prefit is not None else window_fit(
            model, short, specs, max_nfev, progress, span, step, reweight, prior)
        z_first = np.clip(np.array([pre.values[s.path]["value"] for s in vs], float),
                          lo, hi) / sc
    last_jac = {}
    if vs:
        z0 = theta0 / sc
        # the starting point is already simulated: hand it to the optimiser's first call
        r0 = obj.full(rps0, theta0)
        rms_start = _series_rms(obj, rps0)
        cache = {tuple(np.round(z0, 15)): r0}
        obj.best = (float(r0 @ r0), theta0.copy())
        mark = len(obj.trace)   # where the last pass's costs start

        def fun(z):
            key = tuple(np.round(z, 15))
            if key not in cache:
                cache.clear()
                cache[key] = obj.residuals(z * sc)
            return cache[key]

        # long records, started from the window's fit (near the optimum): the Jacobian is
        # differenced once and then updated from each step's change of the residuals (Broyden's
        # rank-one update), one replay a step instead of one per parameter; the covariance
        # below is differenced afresh at the end point
        broyden = {} if short is not None else None

        def jac(z):
            r = fun(z)
            if broyden:
                Jz, dz = broyden["J"], z - broyden["z"]
                if dz @ dz > 0:
                    Jz = Jz + np.outer(r - broyden["r"] - Jz @ dz, dz / (dz @ dz))
            else:
                J = _fd_jacobian(obj, z * sc, r, sc, lo, hi)
                # kept for the covariance: the same point and weights give the same columns
                last_jac.clear()
                last_jac["theta"], last_jac["J"] = z * sc, J
                Jz = J * sc
            if broyden is not None:
                broyden.update(J=Jz, z=np.array(z, float), r=r)
            return Jz

        try:
            budget = max_nfev if broyden is None else min(POLISH_NFEV, max_nfev)
            sol = least_squares(fun, z_first, jac=jac, bounds=(lo / sc, hi / sc), method="trf",
                                x_scale=1.0, max_nfev=budget, ftol=1e-8, xtol=1e-8, gtol=1e-10)
            sigma_before = [dict(d) for d in obj.sigma]
            if reweight and _reweight(obj, obj.replays(sol.x * sc), rms_start):
                cache.clear()
                last_jac.clear()
                if broyden:   # the rows of the updated Jacobian follow the new weights
                    f = _row_factors(obj, sigma_before)
                    broyden["J"] = broyden["J"] * f[:, None]
                    broyden["r"] = broyden["r"] * f
                # the start stays a candidate under the new weights: never a result worse
                # than the model as given on the fit's own objective
                r_start = obj.full(rps0, theta0)
                obj.best = (float(r_start @ r_start), theta0.copy())
                mark = len(obj.trace)
                sol = least_squares(fun, np.clip(sol.x, lo / sc, hi / sc), jac=jac,
                                    bounds=(lo / sc, hi / sc), method="trf", x_scale=1.0,
                                    max_nfev=(max(max_nfev // 2, 5) if broyden is None
                                              else budget), ftol=1e-8, xtol=1e-8,
                                    gtol=1e-10)
            theta = np.clip(sol.x * sc, lo, hi)
            success = sol.status > 0
            message = sol.message if success else f"did not converge: {sol.message}"
            out_of_budget = sol.status == 0 and broyden is None
            if broyden is not None and sol.status == 0:   # the polish's budget, by design
                success = pre.success if pre is not None else True
                message = (f"{pre.message} (on the records' first {PREFIT_SECONDS:g} s in all), "
                           if pre is not None else "started from a fit on these records, ") + \
                    f"then {budget} evaluations a pass on the full records"
        except Cancelled:
            raise
        except Exception as exc:  # keep the best point found, never NaN
            success = False
            message = f"fit failed ({exc}); returning the best point found"
            theta = obj.best[1] if obj.best[1] is not None else theta0
    drop = tail_drop(obj.trace[mark:]) if vs else float("nan")
    rps1 = obj.replays(theta)
    if vs:
        r_end = obj.full(rps1, theta)
        if obj.best[1] is not None and obj.best[0] < float(r_end @ r_end):
            theta = obj.best[1]
            rps1 = obj.replays(theta)
    if not statistics:   # the point alone (and its residual energy): what a fit started from
        # it reads, and what the forms' comparison on the window reads
        return Calibration(obj.model_at(theta), {s.path: {"value": float(theta[i])}
                                                 for i, s in enumerate(vs)}, {}, before, None,
                           math.nan, math.nan, math.nan, 0, len(vs), success, message, obj.n_eval,
                           rss_after=obj.rss(rps1), tail_drop=drop,
                           out_of_budget=out_of_budget)
    after = summarise(rps1)
    rss1 = obj.rss(rps1)
    m2ll, aic, bic, n_all = information_criteria(rss1, len(vs))
    m2ll0, aic0, bic0, _ = information_criteria(rss0, 0)
    # covariance from the Jacobian with residuals scaled by their fitted RMS per (experiment, signal)
    values = {}
    corr = {}
    taus = residual_times(rps1)
    if vs:
        r1 = obj.full(rps1, theta)
        # the data's information alone (the prior's rows dropped): a direction the records do
        # not resolve keeps its large standard error and its correlations, so the confounding is
        # reported (the prior only chose the point along it)
        n_pr = obj.prior_rows(theta).size
        if "theta" in last_jac and np.array_equal(last_jac["theta"], theta):
            J = last_jac["J"][:r1.size - n_pr]
        else:
            J = _fd_jacobian(obj, theta, r1, sc, lo, hi)[:r1.size - n_pr]
        scale = _rms_scale(obj, rps1, taus)
        # covariance in scaled units (parameters of very different sizes, e.g. a
        # conductance of 1e-10 next to h = 25, would make J^T J numerically singular)
        Jz = (J * sc[None, :]) / scale[:, None]
        try:
            cov_z = np.linalg.pinv(Jz.T @ Jz)
        except np.linalg.LinAlgError:
            cov_z = np.full((len(vs), len(vs)), np.nan)
        cov_z = 0.5 * (cov_z + cov_z.T)
        se = np.sqrt(np.clip(np.diag(cov_z), 0, None)) * sc
        se_prior = None
        if n_pr:
            # with the prior's rows (unit variance by construction): how well each value is known
            # given the user's values along what the data do not resolve
            Jp = obj.prior_jacobian(sc)
            try:
                cov_p = np.linalg.pinv(Jz.T @ Jz + Jp.T @ Jp)
                se_prior = np.sqrt(np.clip(np.diag(cov_p), 0, None)) * sc
            except np.linalg.LinAlgError:
                se_prior = None
        dz = np.sqrt(np.clip(np.diag(cov_z), 0, None))
        dz = np.where(dz > 0, dz, np.nan)
        cm = np.clip(cov_z / np.outer(dz, dz), -1.0, 1.0)
        for i, s in enumerate(vs):
            values[s.path] = {"value": float(theta[i]), "stderr": float(se[i]), "initial": s.value,
                              "min": s.min, "max": s.max, "unit": s.unit,
                              "at_bound": at_bound(theta[i], s.min, s.max, sc[i])}
            if se_prior is not None:
                values[s.path]["stderr_prior"] = float(se_prior[i])
            corr[s.path] = {t.path: (float(cm[i, j]) if np.isfinite(cm[i, j]) else None)
                            for j, t in enumerate(vs)}
    for p, v in obj.fixed.items():
        values[p] = {"value": v, "stderr": 0.0, "vary": False}
    return Calibration(obj.model_at(theta), values, corr, before, after, aic, bic, m2ll, n_all,
                       len(vs), success, message, obj.n_eval,
                       taus, rss1, rss0, aic0, bic0, tail_drop=drop,
                       out_of_budget=out_of_budget)


def tail_drop(costs):
    """Share of the residual energy removed over the second half of a fit's evaluations [-]:
    ``1 - best_end / best_middle`` of the best cost after each evaluation (``costs``), 0 for a
    fit of fewer than four; a fit stopped by its budget that was still gaining this much is
    worth going on with (:func:`pneucore.analysis.diagnosis.stages.out_of_evaluations`)."""
    if len(costs) < 4:
        return 0.0
    mid, end = costs[len(costs) // 2 - 1], costs[-1]
    return float(1.0 - end / mid) if mid > 0 and np.isfinite(mid) else 0.0


#: Distance to a bound, as a fraction of the bound's own size (or, for a bound at 0, of the
#: parameter's scale in the fit), within which a fitted value is at it: the optimiser stops far
#: closer than this when a bound holds it (xtol 1e-8 in scaled units), and a free optimum
#: within 0.1 % of a bound is rare
AT_BOUND = 1e-3


def at_bound(value, lo, hi, scale=None, tol=AT_BOUND):
    """Is ``value`` at ``lo`` or ``hi``, relative to the bound's own scale?

    A leak conductance at 0.99998 of its upper bound is at it (a relative tolerance of
    1e-6 missed it). A bound at 0 has no size of its own: the distance is judged against
    ``scale``, the parameter's scale in the fit (its starting value; without it, the
    range), so that 5 g of wall fitted from 50 g in a range up to 10 t is a value, not
    the bound.
    """
    rng = hi - lo if np.isfinite(hi - lo) else np.inf
    for b in (lo, hi):
        ref = abs(b) if b != 0.0 else (abs(scale) if scale else rng)
        if abs(value - b) <= tol * ref:
            return True
    return bool(value < lo or value > hi)


def _series_rms(obj, replays):
    """RMS of each series' noise-weighted residual: ``[{signal: rms}]`` per experiment [-]."""
    out = []
    for rp, sig in zip(replays, obj.sigma):
        d = {}
        for s in rp.measured:
            m, g = rp.measured[s], rp.simulated[s]
            ok = np.isfinite(m) & np.isfinite(g)
            if ok.any():
                d[s] = math.sqrt(np.mean(((g[ok] - m[ok]) / sig[s]) ** 2))
        out.append(d)
    return out


def _row_factors(obj, old_sigma):
    """Factor of each residual row of :meth:`Objective.full` when the weights go from
    ``old_sigma`` to ``obj.sigma`` (1 on the prior's rows) [-]."""
    parts = []
    for e, sig, sig0 in zip(obj.experiments, obj.sigma, old_sigma):
        for s in e.signals:
            n = int(np.isfinite(e.measurement.signals[s]).sum())
            parts.append(np.full(n, sig0[s] / sig[s]))
    parts.append(np.ones(obj._prior_idx.size))
    return np.concatenate(parts)


def _reweight(obj, replays, cap=None):
    """Scale each series' noise level by the RMS of its weighted residual (floored at 1).

    ``cap`` (:func:`_series_rms` of the starting point) bounds each factor by the
    series' own misfit at the start: the reweighting may discount a series only down
    to what the model as given already achieved on it. Without the cap, a misspecified
    model with few samples per series (a vessel's pressure and gas temperature, ~15
    points each) lets the fit give up the series it can no longer follow and collapse
    onto the other (pressure error 1.3 % -> 21.5 % for a better temperature).

    Returns True when some weight changed by more than 10 % (a second pass is worth it).
    """
    changed = False
    for k, (d, sig) in enumerate(zip(_series_rms(obj, replays), obj.sigma)):
        for s, rms in d.items():
            if cap is not None:
                rms = min(rms, max(cap[k].get(s, rms), 1.0))
            if rms > 1.1:
                sig[s] *= rms
                changed = True
    return changed


def _rms_scale(obj, replays, taus=None):
    """Per-residual factor turning noise-weighted residuals into unit-variance ones.

    With ``taus`` (:func:`pneucore.analysis.autocorrelation.residual_times` of the same
    replays) the factor of a series is also multiplied by ``sqrt(tau)``: its n
    samples then weigh as n / tau independent ones.
    """
    parts = []
    k = 0
    for rp, sig in zip(replays, obj.sigma):
        for s in rp.measured:
            m, g = rp.measured[s], rp.simulated[s]
            ok = np.isfinite(rp.experiment.measurement.signals[s])
            okn = np.isfinite(m) & np.isfinite(g)
            rms = math.sqrt(np.mean(((g[okn] - m[okn]) / sig[s]) ** 2)) if okn.any() else 1.0
            if taus is not None:
                rms *= math.sqrt(taus[k][1])
            k += 1
            parts.append(np.full(int(ok.sum()), max(rms, 1e-12)))
    return np.concatenate(parts)


def calibrate(model, experiments, parameters, max_nfev=40, datasets=None, progress=None):
    """Fit model parameters to measurements.

    Parameters
    ----------
    model : Model or dict
        Starting model
    experiments : list
        Experiments (objects or JSON), fitted jointly
    parameters : dict or list
        ``{path: {"min", "max", "value"?, "vary"?}}`` (see :mod:`pneucore.description.paths`)
    max_nfev : int
        Budget of residual evaluations of the optimiser
    progress : callable or None
        ``progress(fraction, step)``; may raise ``Cancelled``

    Returns
    -------
    calibration : Calibration
        Calibrated model, values with standard errors, correlations,
        Eq. 25 errors before and after (per signal and phase), AIC, BIC and ``summary()``.
        A fit that does not converge says so in ``success``/``message`` and returns the
        best point found.
    """
    model = Model.from_dict(model) if not isinstance(model, Model) else model
    exps = Records(as_experiments(experiments, model.ambient.pressure, datasets))
    specs = check_parameters(model, exps, parameters)
    return kept_better(model, fit(model, exps, specs, max_nfev=max_nfev, progress=progress,
                                  step="calibrating"))


def kept_better(model, cal):
    """``cal``, or the model as given where the fit raised the overall error (issue 39).

    The fit keeps its best point on its own objective (the weighted residuals); the error the
    user reads is Eq. 25's overall error, and a fit may lower the one and raise the other (a
    sensor offset traded against a pressure's shape). Then the model as given is kept: its
    values, its errors after equal to before, ``kept_start`` set, each fitted value under
    ``fitted`` (not applied) and the message saying so.

    Parameters
    ----------
    model : Model
        The model the fit started from [-]
    cal : Calibration
        The fit's result [-]

    Returns
    -------
    calibration : Calibration
        ``cal`` itself, changed as above where its error is the higher [-]
    """
    b = getattr(cal.error_before, "overall", None)
    a = getattr(cal.error_after, "overall", None)
    if b is None or not math.isfinite(b) or (a is not None and math.isfinite(a) and a <= b):
        return cal
    for v in cal.values.values():
        if v.get("vary", True) is not False and "initial" in v:
            v["fitted"] = v["value"]
            v["value"] = v["initial"]
    cal.model = model
    cal.error_after = cal.error_before
    cal.aic, cal.bic = cal.aic_before, cal.bic_before
    cal.rss_after = cal.rss_before
    cal.kept_start = True
    worse = "not computable" if a is None or not math.isfinite(a) else f"{100 * a:.2f} %"
    cal.message = (f"{cal.message}; the fitted values raise the overall error (Eq. 25) from "
                   f"{100 * b:.2f} % to {worse}: the model as given is kept (the fitted values "
                   f"are listed as 'fitted', not applied)")
    return cal


def check_parameters(model, experiments, parameters):
    """The specs of a calibration's ``parameters``: model paths (:func:`parse_parameters`) and
    sensor paths (:data:`SENSOR_PREFIX`: ``sensors.x.offset``, ``sensors.p_a.gain``) of a signal
    the experiments measure; each error names its ``parameters.<path>``."""
    from pneucore.description.validation import FieldError
    if isinstance(parameters, (list, tuple)):
        parameters = {p: {} for p in parameters}
    sensor = {p: o for p, o in (parameters or {}).items() if str(p).startswith(SENSOR_PREFIX)}
    rest = {p: o for p, o in (parameters or {}).items() if p not in sensor}
    specs = parse_parameters(model, rest) if rest or not sensor else []
    measured = {s for e in experiments for s in e.signals}
    for p, opts in sensor.items():
        sp = sensor_path(p)
        if sp is None or sp[0] not in measured:
            raise FieldError(f"parameters.{p}", "a sensor parameter is sensors.<signal>.offset or "
                                                f".gain of a measured signal ({', '.join(sorted(measured))})")
        if opts is not None and not isinstance(opts, dict):
            raise FieldError(f"parameters.{p}", "must be an object with min/max/value/vary")
        specs += sensor_specs(experiments, [sp[0]], [sp[1]], {p: opts})
    return specs
