"""Features of a step-0 binaural clip for the audio perception module.

What a listener can tell from the fall's sound, as a fixed-length vector (:class:`AudioFeatures`
holds the settings and names every entry):

- its spectrum: log mel-band energies of each ear over ``window_s`` after the onset (what the
  object and its material ring at), and their difference between the ears (the interaural
  level difference per band: where it is, the head shadowing the high bands);
- its decay: the energy of four band groups in successive slices after the onset against the
  first slice (a glass rings on, a cushion thuds; the room's reverberation);
- where it is: the interaural time difference by generalised cross-correlation (GCC-PHAT-beta)
  within ``max_itd_s``, over the direct sound (4 ms from the onset) and longer windows, and the
  correlation's peaks; the difference of the ears' first-arrival times; the direct sound's
  level difference between the ears per band group; the direct sound's share of the first 80 ms
  (near falls are drier); the level. Row 0 of a clip is the left ear. The interaural time
  difference is the right ear's arrival time minus the left ear's, in ms, as everywhere in
  fallgen (:mod:`fallgen.audio.hrtf`): ITD > 0, the source is on the left, the left ear hears
  it first (version 5; up to version 4 the sign was the other way round);
- when it is: the onset time in the clip (a fall from higher lands later);
- its echoes: the power cepstrum of each ear's first 40 ms and the autocorrelation of their
  sum, per delay bin (the agent's own distance to the floor and the walls: a cue to how far the
  fall was);
- how far it is: direct-to-reverberant ratios, the energy of both ears from 0.5 ms before the
  onset to ``drr_direct_ms`` after it against that in each of ``drr_late_ms`` (the direct
  sound falls 6 dB per doubling of distance, the room's diffuse field hardly changes), broadband
  (the ambient noise's share of the late window taken off) and in the octave bands
  ``drr_bands_hz``; and the strongest arrival above 1 kHz 2-15 ms after the direct one
  (the ceiling's and the walls' first reflections: its level against the direct sound's, and
  its delay). Each alone ranks the test falls' distances at 0.2-0.25 (Spearman) on the
  paper-size build: an impact's own ring and bounces share both windows.

The onset is the first frame whose energy reaches 1 % of the loudest frame's, refined to the
first sample there that reaches a tenth of the peak. Pure numpy; a clip of 2 x 88200 samples
takes ~12 ms on the 2-core dev VM.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from functools import cached_property

import numpy as np

EPS = 1e-12


@dataclass(frozen=True)
class AudioFeatures:
    sample_rate: int = 44100
    #: samples per clip (the dataset's ``audio_s`` times its sample rate)
    clip_samples: int = 88200
    frame: int = 1024
    hop: int = 256
    n_mels: int = 32
    fmin_hz: float = 60.0
    fmax_hz: float = 16000.0
    #: the spectrum is averaged over this long after the onset (s)
    window_s: float = 0.6
    #: edges (s after the onset) of the slices the decay is measured in
    slices_s: tuple[float, ...] = (0.0, 0.03, 0.1, 0.25, 0.6)
    #: band groups of the decay (the mel bands split evenly)
    groups: int = 4
    #: the largest interaural time difference looked for (s; a head is ~0.7 ms across)
    max_itd_s: float = 0.001
    #: the windows (s from just before the onset) the interaural time difference is taken
    #: over: the direct sound alone, then with the first reflections
    itd_windows_s: tuple[float, ...] = (0.004, 0.012, 0.05)
    #: the direct sound's window for the interaural level difference per band group (s)
    direct_s: float = 0.006
    #: the cross-spectrum's weighting |G|^-beta in the generalised cross-correlation: 1 is
    #: PHAT, which gives the ambient noise's bins (coherent between the ears at zero lag) as
    #: much weight as the fall's; 0.7 (Donohue et al. 2007's PHAT-beta) keeps the sharp peak
    #: and lets the fall's strong bins lead (direct-sound ITDs within 0.1 ms of Woodworth's:
    #: 62 % of the paper-size build's test clips, against 44 % with PHAT)
    phat_beta: float = 0.7
    #: levels (shares of the direct sound's peak) at which each ear's first arrival is timed:
    #: the onset-time difference between the ears, another estimate of the ITD
    onset_levels: tuple[float, ...] = (0.05, 0.1)
    #: quefrency / lag bins (ms) where the echoes of the first 40 ms are looked for (the
    #: agent's own distance to the floor and the walls, a cue to how far the fall was)
    echo_bins_ms: tuple[float, ...] = (0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 30.0)
    #: direct windows (ms after the onset) of the direct-to-reverberant ratios
    drr_direct_ms: tuple[float, ...] = (3.0, 5.0)
    #: their reverberant windows (ms after the onset, pairs)
    drr_late_ms: tuple[tuple[float, float], ...] = ((20.0, 50.0), (50.0, 300.0))
    #: octave bands (centre Hz) of the ratios besides the broadband one
    drr_bands_hz: tuple[float, ...] = (250.0, 1000.0, 2000.0)
    #: 5: the interaural time differences are > 0 when the left ear hears first (4 and
    #: before: when it hears later); 6: the direct-to-reverberant ratios and the first
    #: reflection; a model trained on other versions is refused
    version: int = 6

    def to_dict(self) -> dict:
        d = asdict(self)
        d["slices_s"] = list(self.slices_s)
        d["itd_windows_s"] = list(self.itd_windows_s)
        d["onset_levels"] = list(self.onset_levels)
        d["echo_bins_ms"] = list(self.echo_bins_ms)
        d["drr_direct_ms"] = list(self.drr_direct_ms)
        d["drr_late_ms"] = [list(w) for w in self.drr_late_ms]
        d["drr_bands_hz"] = list(self.drr_bands_hz)
        return d

    @staticmethod
    def from_dict(d: dict) -> AudioFeatures:
        d = dict(d)
        d["slices_s"] = tuple(d["slices_s"])
        d["itd_windows_s"] = tuple(d.get("itd_windows_s", ()))
        for key in ("onset_levels", "echo_bins_ms", "drr_direct_ms", "drr_bands_hz"):
            if key in d:
                d[key] = tuple(d[key])
        if "drr_late_ms" in d:
            d["drr_late_ms"] = tuple(tuple(w) for w in d["drr_late_ms"])
        return AudioFeatures(**d)

    @cached_property
    def names(self) -> tuple[str, ...]:
        m = range(self.n_mels)
        out = [f"mel_l{k}" for k in m] + [f"mel_r{k}" for k in m] + [f"ild{k}" for k in m]
        out += [f"decay_s{s}_g{g}" for s in range(1, len(self.slices_s) - 1)
                for g in range(self.groups)]
        out += [f"itd_{int(w * 1e3)}ms" for w in self.itd_windows_s]
        out += [f"gcc_peak_{int(w * 1e3)}ms" for w in self.itd_windows_s]
        out += [f"itd_onset{int(round(v * 100))}" for v in self.onset_levels]
        out += [f"ild_direct_g{g}" for g in range(self.groups)]
        out += ["ild_onset_db", "direct_l", "direct_r", "peak_db", "rms_db", "centroid_log_hz",
                "onset_s"]
        bins = [f"{a:g}_{b:g}ms" for a, b in zip(self.echo_bins_ms[:-1], self.echo_bins_ms[1:])]
        out += [f"cep_{ear}_{b}" for ear in "lr" for b in bins + ["peak"]]
        out += [f"ac_{b}" for b in bins]
        out += [f"drr_{band}_{d:g}ms_{a:g}_{b:g}ms"
                for band in ["bb"] + [f"{f:g}hz" for f in self.drr_bands_hz]
                for d in self.drr_direct_ms for a, b in self.drr_late_ms]
        out += ["reflection_db", "reflection_ms"]
        return tuple(out)

    @cached_property
    def spatial(self) -> np.ndarray:
        """Indices of the entries that tell where the fall was (the ears' differences, the
        direct sound's share, the level, the onset): what the direction's model learns from
        (the distance's learns from every entry)."""
        keep = ("ild", "itd_", "gcc_", "direct_", "peak_db", "rms_db", "onset_s", "cep_", "ac_")
        return np.array([i for i, n in enumerate(self.names) if n.startswith(keep)])

    @cached_property
    def _mel(self) -> np.ndarray:
        """(n_mels, frame // 2 + 1) triangular filters, evenly spaced on the mel scale (HTK)."""
        def mel(f):
            return 2595.0 * np.log10(1.0 + np.asarray(f) / 700.0)

        def hz(m):
            return 700.0 * (10.0 ** (np.asarray(m) / 2595.0) - 1.0)

        edges = hz(np.linspace(mel(self.fmin_hz), mel(self.fmax_hz), self.n_mels + 2))
        freqs = np.fft.rfftfreq(self.frame, 1.0 / self.sample_rate)
        lo, mid, hi = edges[:-2, None], edges[1:-1, None], edges[2:, None]
        up = (freqs[None, :] - lo) / (mid - lo)
        down = (hi - freqs[None, :]) / (hi - mid)
        return np.clip(np.minimum(up, down), 0.0, None)

    def extract(self, audio: np.ndarray) -> np.ndarray:
        """The feature vector (float32, ``len(self.names)``) of a (2, clip_samples) clip."""
        x = np.asarray(audio, np.float64)
        if x.shape != (2, self.clip_samples):
            raise ValueError(f"a clip of shape {x.shape}, the features expect "
                             f"(2, {self.clip_samples})")
        fs, hop = self.sample_rate, self.hop
        n_frames = 1 + (x.shape[1] - self.frame) // hop
        idx = np.arange(self.frame)[None, :] + hop * np.arange(n_frames)[:, None]
        spec = np.fft.rfft(x[:, idx] * np.hanning(self.frame), axis=-1)  # (2, F, bins)
        power = spec.real ** 2 + spec.imag ** 2
        mel = power @ self._mel.T  # (2, F, M)
        energy = mel.sum(axis=(0, 2))
        onset = int(np.argmax(energy >= 0.01 * energy.max()))
        win = max(1, int(round(self.window_s * fs / hop)))
        seg = mel[:, onset:onset + win]
        band = np.log10(seg.mean(axis=1) + EPS)  # (2, M)
        feats = [band[0], band[1], band[0] - band[1]]
        # decay: each band group's energy per slice against the first slice
        groups = np.array_split(np.arange(self.n_mels), self.groups)
        edges = [onset + int(round(s * fs / hop)) for s in self.slices_s]
        per = [[mel[:, a:max(b, a + 1)][..., g].sum() for g in groups]
               for a, b in zip(edges[:-1], edges[1:])]
        per = np.log10(np.asarray(per) + EPS)  # (slices, groups)
        feats.append((per[1:] - per[:1]).ravel())
        # the onset to the sample: where the clip first reaches a tenth of its peak over the
        # onset frame and the 50 ms after it (a frame is 23 ms long)
        a0 = onset * hop
        env = np.abs(x[:, a0:a0 + self.frame + int(0.05 * fs)]).max(axis=0)
        first = a0 + int(np.argmax(env >= 0.1 * env.max())) if env.size else a0
        s0 = max(0, first - int(0.001 * fs))  # from 1 ms before it
        # where: GCC-PHAT over windows from the onset (the direct sound, then more)
        lag = int(round(self.max_itd_s * fs))
        itds, peaks = [], []
        for w in self.itd_windows_s:
            n = int(w * fs)
            left, right = x[0, s0:s0 + n], x[1, s0:s0 + n]
            nfft = 1 << int(math.ceil(math.log2(2 * max(len(left), 1))))
            cross = np.fft.rfft(left, nfft) * np.conj(np.fft.rfft(right, nfft))
            cc = np.fft.irfft(cross / (np.abs(cross) + EPS) ** self.phat_beta, nfft)
            window = np.concatenate([cc[-lag:], cc[:lag + 1]])  # lags -lag .. lag
            k = int(np.argmax(window))
            # the left ear's signal matches the right's k - lag samples later: the right
            # ear's arrival minus the left's is lag - k (> 0: the left ear hears it first)
            itds.append((lag - k) / fs * 1e3)
            peaks.append(float(window[k]))
        # each ear's first arrival: where it first reaches a share of the direct sound's peak
        # (2 ms before the onset to 10 ms after it): the right ear's time minus the left's
        # (> 0: the left ear hears it first)
        a = max(0, first - int(0.002 * fs))
        near = np.abs(x[:, a:first + int(0.01 * fs)])
        top = float(near.max()) if near.size else 0.0
        onset_itds = []
        for v in self.onset_levels:
            t_l, t_r = (int(np.argmax(e >= v * top)) for e in near) if top > 0 else (0, 0)
            onset_itds.append(float(np.clip((t_r - t_l) / fs * 1e3, -1e3 * self.max_itd_s,
                                            1e3 * self.max_itd_s)))
        # the direct sound's level difference per band group
        n = max(int(self.direct_s * fs), 64)
        direct_sound = x[:, s0:s0 + n]
        ml, mr = np.abs(np.fft.rfft(direct_sound * np.hanning(direct_sound.shape[1]),
                                    self.frame, axis=-1)) ** 2 @ self._mel.T
        ild_direct = [10 * math.log10((ml[g].sum() + EPS) / (mr[g].sum() + EPS)) for g in groups]
        left, right = x[0, s0:s0 + int(0.05 * fs)], x[1, s0:s0 + int(0.05 * fs)]
        e_l, e_r = float((left ** 2).sum()), float((right ** 2).sum())
        ild_onset = 10 * math.log10((e_l + EPS) / (e_r + EPS))
        d = int(0.005 * fs)
        tail = x[:, s0:s0 + int(0.08 * fs)] ** 2
        direct = [math.log10((t[:d].sum() + EPS) / (t[d:].sum() + EPS)) for t in tail]
        peak_db = 20 * math.log10(float(np.abs(x).max()) + EPS)
        rms_db = 10 * math.log10(float((x[:, s0:s0 + win * hop] ** 2).mean()) + EPS)
        freqs = np.fft.rfftfreq(self.frame, 1.0 / fs)
        p = power[:, onset:onset + win].sum(axis=(0, 1))
        centroid = float((p * freqs).sum() / (p.sum() + EPS))
        feats.append(np.array([*itds, *peaks, *onset_itds, *ild_direct, ild_onset, *direct, peak_db,
                               rms_db, math.log10(centroid + 1.0), first / fs]))
        feats.append(self._echoes(x, max(0, first - int(0.0005 * fs))))
        feats.append(self._reverberance(x, first, power))
        out = np.concatenate(feats).astype(np.float32)
        assert len(out) == len(self.names)
        return out


    def _echoes(self, x: np.ndarray, s0: int) -> np.ndarray:
        """Echoes in the first 40 ms from ``s0``: each ear's power cepstrum's largest value per
        quefrency bin and the quefrency (ms) of its largest from 1 ms on (a reflection delayed
        by tau puts a peak at tau), and the two ears' sum's normalised autocorrelation's
        largest value per lag bin."""
        fs = self.sample_rate
        seg = x[:, s0:s0 + int(0.04 * fs)]
        edges = np.asarray(self.echo_bins_ms)
        out = []
        nfft = 4096
        q = np.arange(nfft) / fs * 1e3
        for ear in seg:
            spec = np.fft.rfft(ear * np.hanning(len(ear)), nfft) if len(ear) else np.zeros(1)
            cep = np.fft.irfft(np.log(np.abs(spec) ** 2 + EPS), nfft)
            out += [float(cep[(q >= a) & (q < b)].max()) for a, b in zip(edges[:-1], edges[1:])]
            k = (q >= 1.0) & (q < edges[-1])
            out.append(float(q[k][np.argmax(cep[k])]))
        both = seg.sum(axis=0)
        ac = np.correlate(both, both, "full")[len(both) - 1:] if len(both) else np.zeros(1)
        ac = ac / (ac[0] + EPS)
        lags = np.arange(len(ac)) / fs * 1e3
        for a, b in zip(edges[:-1], edges[1:]):
            sel = ac[(lags >= a) & (lags < b)]
            out.append(float(sel.max()) if sel.size else 0.0)
        return np.asarray(out)


    def _band_pass(self, lo_hz: float, hi_hz: float) -> np.ndarray:
        """A fourth-order Butterworth band-pass, as second-order sections."""
        from scipy.signal import butter

        return butter(4, (lo_hz, min(hi_hz, 0.49 * self.sample_rate)), "bandpass",
                      fs=self.sample_rate, output="sos")

    @cached_property
    def _octaves(self) -> dict[float, np.ndarray]:
        """The octave band-passes of the ratios' bands, by centre frequency."""
        return {f: self._band_pass(f / math.sqrt(2), f * math.sqrt(2))
                for f in self.drr_bands_hz}

    @cached_property
    def _reflection_band(self) -> np.ndarray:
        """The 1-8 kHz band-pass the first reflection is looked for in."""
        return self._band_pass(1000.0, 8000.0)

    def _reverberance(self, x: np.ndarray, first: int, power: np.ndarray) -> np.ndarray:
        """The direct-to-reverberant ratios (log10) and the first reflection (dB against the
        direct sound, delay ms) of a clip whose direct sound starts at sample ``first``;
        ``power``: its frames' power spectra (the quietest frame gives the noise floor)."""
        from scipy.signal import sosfilt

        fs = self.sample_rate
        late_end = max(b for _, b in self.drr_late_ms)
        a = max(0, first - int(0.0005 * fs))
        seg = x[:, a:first + int(late_end * 1e-3 * fs)]
        # each frame's mean power per sample, both ears (Parseval: the one-sided spectrum
        # of a Hann-windowed frame holds about N / 2 times its windowed energy)
        w = np.hanning(self.frame)
        noise = float(power.sum(axis=(0, 2)).min()) / (self.frame / 2 * float(w @ w))

        def window(p: np.ndarray, lo_ms: float, hi_ms: float) -> float:
            i0 = first - a + int(lo_ms * 1e-3 * fs)
            return float(p[i0:first - a + int(hi_ms * 1e-3 * fs)].sum())

        out = []
        signals = [(True, seg)] + [(False, sosfilt(self._octaves[f], seg, axis=-1))
                                   for f in self.drr_bands_hz]
        for broadband, sig in signals:
            p = (sig ** 2).sum(axis=0)
            for d in self.drr_direct_ms:
                direct = float(p[:first - a + int(d * 1e-3 * fs)].sum())
                for lo, hi in self.drr_late_ms:
                    late = window(p, lo, hi)
                    if broadband:  # the ambient noise's share of the late window taken off
                        late = max(late - noise * (hi - lo) * 1e-3 * fs, 0.05 * late)
                    out.append(math.log10((direct + EPS) / (late + EPS)))
        # the strongest arrival above 1 kHz 2-15 ms after the direct one (its peak within
        # 3 ms of the onset), from 1 ms before the onset
        b0 = max(0, first - int(0.001 * fs))
        hp = sosfilt(self._reflection_band, x[:, b0:b0 + int(0.025 * fs)], axis=-1)
        env = (hp ** 2).sum(axis=0)
        d0 = int(np.argmax(env[:int(0.003 * fs)])) if len(env) else 0
        later = env[d0 + int(0.002 * fs):d0 + int(0.015 * fs)]
        if later.size:
            k = int(np.argmax(later))
            out += [10 * math.log10((later[k] + EPS) / (env[d0] + EPS)),
                    (k + int(0.002 * fs)) / fs * 1e3]
        else:
            out += [0.0, 0.0]
        return np.asarray(out)


def relative_place(row: dict) -> tuple[float, float]:
    """(azimuth rad, distance m) of where the object came to rest, seen from the agent's spawn
    (azimuth counter-clockwise from its heading, in (-pi, pi])."""
    dx = row["settle_pos"][0] - row["spawn_x"]
    dy = row["settle_pos"][1] - row["spawn_y"]
    az = math.atan2(dy, dx) - row["spawn_yaw_rad"]
    return math.atan2(math.sin(az), math.cos(az)), math.hypot(dx, dy)
