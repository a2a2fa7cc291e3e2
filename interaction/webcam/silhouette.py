"""Who stands in front of the webcam: a frozen background, light compensation, shadow suppression.

The background is the per-pixel median of the first frames (the stage is empty then), along with
each pixel's own noise (the spread of its values over those frames). Both come from the frames
sorted per pixel, which is built up frame by frame while learning (each frame is sorted into place,
one min/max pass), so the frame that ends learning costs no more than any other. A frame is compared against it after undoing global light change (a gain
per colour channel, measured where no one stood in the last frame). A pixel is foreground when its
colour is far from the background's, unless it is merely a shadow or a local light: darker or
brighter by a bounded ratio with the background's colour. The background follows the room slowly
wherever no person stands (every frame), and everywhere once no one has been in view for a while.
"""

from __future__ import annotations

import cv2
import numpy as np

from interaction.webcam.config import WebcamObserverConfig

__all__ = ["BackgroundModel"]

_GAIN_STRIDE = 6  # measure the light gain on every 6th pixel in each direction
_MIN_BG_LEVEL = 12.0  # background channel values below this tell nothing about the gain
_IQR_PER_SIGMA = 1.349  # a normal distribution's interquartile range, in σ
_MAX_THRESHOLD_SHARE = 2.0  # a pixel's noise raises its threshold to at most this many diff_threshold,
_MAX_THRESHOLD_NOISE = 3.0  # ... or this many times the median pixel's (a camera's own noise)
_CHANNEL_MEAN = np.full((1, 3), 1.0 / 3.0, dtype=np.float32)
_ONES = np.ones((1, 3), dtype=np.float32)  # sums a pixel's three channels


class BackgroundModel:
    """The learned empty stage and the per-frame foreground test against it."""

    def __init__(self, config: WebcamObserverConfig) -> None:
        self._cfg = config
        k = config.morphology_px | 1  # odd: an even kernel's open/close shifts the mask by a pixel
        self._kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))
        # bridges a body cut across by a band that looks like the background (a belt, a lit thigh as
        # bright as the floor): up and down only, so the gaps between the legs and beside the arms stay
        self._bridge = cv2.getStructuringElement(cv2.MORPH_RECT, (1, 2 * k + 1))
        self._sorted: list[np.ndarray] = []  # the learning frames, sorted per pixel and channel (uint8)
        self._bg: np.ndarray | None = None  # float32 (H, W, 3)
        self._bg_sq: np.ndarray | None = None  # its square, per channel
        self._thr2: np.ndarray | None = None  # float32 (H, W): squared distance threshold per pixel
        self._thr2_quarter: np.ndarray | None = None  # a quarter of it (the shadow test's slack)
        self._arrays: _ForegroundArrays | None = None  # the per-frame work arrays, made by the first frame
        self._gain = (1.0, 1.0, 1.0)
        self._empty_run = 0
        self._outside: np.ndarray | None = None  # where no person stands (the selective refresh's mask)

    # ------------------------------------------------------------ state

    @property
    def learning(self) -> bool:
        return self._bg is None

    @property
    def size(self) -> tuple[int, int] | None:
        """(width, height) of the learned background, or of the frames being learned."""
        ref = self._bg if self._bg is not None else (self._sorted[0] if self._sorted else None)
        return None if ref is None else (int(ref.shape[1]), int(ref.shape[0]))

    @property
    def background(self) -> np.ndarray | None:
        """The learned background as uint8 BGR (a copy), or None while learning."""
        return None if self._bg is None else np.clip(self._bg + 0.5, 0, 255).astype(np.uint8)

    @property
    def gain(self) -> tuple[float, float, float]:
        """The last measured light gain per channel (B, G, R): frame ≈ gain × background."""
        return self._gain

    def relearn(self) -> None:
        """Forget the background; the next ``learn_frames`` frames learn it again."""
        self._forget_learning()
        self._bg = None
        self._bg_sq = None
        self._thr2 = None
        self._thr2_quarter = None
        self._gain = (1.0, 1.0, 1.0)
        self._empty_run = 0

    def learn(self, bgr: np.ndarray) -> None:
        """Take one frame of the empty stage; the last of ``learn_frames`` fixes the background.

        The background is the per-pixel, per-channel median of the frames; each pixel's noise σ the
        root mean square over the channels of their interquartile range over 1.349 (for Gaussian noise
        the σ that the median distance to the background gives; like it, high where something moved
        while learning, so that what was there then does not come back as a ghost)."""
        _insert_sorted(self._sorted, np.array(bgr, dtype=np.uint8, copy=True))
        k = len(self._sorted)
        if k < self._cfg.learn_frames:
            return
        lo, hi = self._sorted[(k - 1) // 2], self._sorted[k // 2]  # the median, as np.median takes it
        bg = (lo.astype(np.float32) + hi.astype(np.float32)) * np.float32(0.5)
        q = (k - 1) // 4
        iqr = cv2.subtract(self._sorted[k - 1 - q], self._sorted[q]).astype(np.float32)
        spread = np.sqrt(cv2.transform(cv2.multiply(iqr, iqr), _CHANNEL_MEAN)) / np.float32(_IQR_PER_SIGMA)
        sigma = cv2.blur(spread.astype(np.float32), (5, 5))
        # capped: where someone moved while learning (a person in view at start) they stay detectable
        base = np.float32(self._cfg.diff_threshold)
        noise = np.float32(self._cfg.noise_sigmas) * sigma
        cap = np.float32(max(float(_MAX_THRESHOLD_SHARE * base), _MAX_THRESHOLD_NOISE * float(np.median(noise))))
        thr = np.clip(noise, base, cap)
        self._bg = bg
        self._bg_sq = bg * bg
        self._thr2 = (thr * thr).astype(np.float32)
        self._thr2_quarter = 0.25 * self._thr2
        self._forget_learning()

    def _forget_learning(self) -> None:
        self._sorted.clear()

    # ------------------------------------------------------------ per frame

    def foreground(self, bgr: np.ndarray, ignore: np.ndarray | None = None) -> np.ndarray:
        """The cleaned foreground mask (uint8 0/255) of a frame: the model's own array, overwritten by the
        next call (copy it to keep it).

        ``ignore`` (uint8/bool, same size) marks pixels to leave out of the light measurement
        (where people stood last frame). Every image-sized step writes into work arrays kept from frame
        to frame (see :class:`_ForegroundArrays`): a frame allocates nothing the size of the image.
        """
        if self._bg is None or self._bg_sq is None or self._thr2 is None or self._thr2_quarter is None:
            raise RuntimeError("BackgroundModel.foreground called while still learning")
        cfg = self._cfg
        a = self._arrays
        if a is None or a.img.shape != self._bg.shape:
            a = self._arrays = _ForegroundArrays(self._bg.shape[:2])
        img = a.img
        np.copyto(img, bgr, casting="unsafe")  # uint8 → float32, exact
        self._gain = self._measure_gain(img, ignore)
        g = np.asarray(self._gain, dtype=np.float32)
        bg = cv2.transform(self._bg, np.diag(g), dst=a.bg)  # the background under this frame's light
        d = cv2.subtract(img, bg, dst=a.diff)
        dd = cv2.transform(cv2.multiply(d, d, dst=a.product), _ONES, dst=a.dd)  # |I − B|²
        fg = np.greater(dd, self._thr2, out=a.fg)
        db = cv2.transform(cv2.multiply(d, bg, dst=a.product), _ONES, dst=a.db)  # (I − B)·B
        bb = cv2.transform(self._bg_sq, (g * g)[None, :], dst=a.bb)
        np.add(bb, np.float32(1e-3), out=bb)  # |B|²
        ratio_minus_1 = np.divide(db, bb, out=a.alpha)  # brightness ratio α − 1, with I ≈ α B + colour distortion
        cd2 = np.subtract(dd, np.multiply(db, ratio_minus_1, out=a.work), out=dd)  # squared colour distortion |I − α B|²
        alpha = np.add(ratio_minus_1, np.float32(1.0), out=a.alpha)
        tol = np.multiply(np.float32(cfg.shadow_colour_tolerance), alpha, out=a.work)
        # shadow or local light: (min ratio <= α <= highlight max) & (cd2 <= tol² |B|² + ¼ thr²)
        bound = np.add(np.multiply(np.multiply(tol, tol, out=tol), bb, out=tol), self._thr2_quarter, out=tol)
        shadow = np.less_equal(cd2, bound, out=a.shadow)
        shadow &= np.greater_equal(alpha, cfg.shadow_min_ratio, out=a.test)
        shadow &= np.less_equal(alpha, cfg.highlight_max_ratio, out=a.test)
        fg &= np.invert(shadow, out=shadow)
        mask = np.multiply(fg.view(np.uint8), np.uint8(255), out=a.mask)
        opened = cv2.morphologyEx(mask, cv2.MORPH_OPEN, self._kernel, dst=a.opened)
        closed = cv2.morphologyEx(opened, cv2.MORPH_CLOSE, self._kernel, dst=a.mask)
        return cv2.morphologyEx(closed, cv2.MORPH_CLOSE, self._bridge, dst=a.opened)

    def refresh(self, bgr: np.ndarray, people: np.ndarray | None) -> None:
        """Blend the frame into the background: at ``adapt_rate`` where no person stands (``people``,
        uint8 255 = a person, grown by the caller; None = no one), and at ``refresh_rate`` everywhere once
        no one has been in view for ``refresh_after_empty_frames`` frames."""
        if self._bg is None or self._bg_sq is None:
            return
        cfg = self._cfg
        self._empty_run = 0 if people is not None else self._empty_run + 1
        if self._empty_run > cfg.refresh_after_empty_frames and cfg.refresh_rate > 0:
            cv2.accumulateWeighted(bgr, self._bg, cfg.refresh_rate)
        elif cfg.adapt_rate > 0 and people is None:
            cv2.accumulateWeighted(bgr, self._bg, cfg.adapt_rate)
        elif cfg.adapt_rate > 0 and people is not None:
            if self._outside is None or self._outside.shape != people.shape:
                self._outside = np.empty_like(people)
            cv2.accumulateWeighted(bgr, self._bg, cfg.adapt_rate, mask=cv2.bitwise_not(people, dst=self._outside))
        else:
            return
        cv2.multiply(self._bg, self._bg, dst=self._bg_sq)

    def grey(self) -> np.ndarray | None:
        """The learned background in grey levels (uint8, a new array), or None while learning."""
        bg = self.background
        return None if bg is None else cv2.cvtColor(bg, cv2.COLOR_BGR2GRAY)

    def absorb(self, bgr: np.ndarray, contour: np.ndarray) -> None:
        """The frame taken as the background inside an outline (M, 2) (a ghost, a changed light)."""
        if self._bg is None or self._bg_sq is None:
            return
        x0, y0 = contour.min(axis=0)
        x1, y1 = contour.max(axis=0) + 1
        inside = np.zeros((y1 - y0, x1 - x0), np.uint8)
        cv2.drawContours(inside, [(contour - np.array([x0, y0])).reshape(-1, 1, 2).astype(np.int32)], -1, 1, cv2.FILLED)
        box = self._bg[y0:y1, x0:x1]
        np.copyto(box, bgr[y0:y1, x0:x1], where=inside[:, :, None] > 0, casting="unsafe")
        np.multiply(box, box, out=self._bg_sq[y0:y1, x0:x1])

    def _measure_gain(self, img: np.ndarray, ignore: np.ndarray | None) -> tuple[float, float, float]:
        assert self._bg is not None
        s = _GAIN_STRIDE
        frame = img[::s, ::s].reshape(-1, 3)
        bg = self._bg[::s, ::s].reshape(-1, 3)
        keep = np.all(bg > _MIN_BG_LEVEL, axis=1)
        if ignore is not None:
            keep &= ignore[::s, ::s].reshape(-1) == 0
        if np.count_nonzero(keep) < 50:
            return self._gain
        ratios = frame[keep] / bg[keep]
        g = np.clip(np.median(ratios, axis=0), 0.25, 4.0)
        return float(g[0]), float(g[1]), float(g[2])


class _ForegroundArrays:
    """The work arrays of :meth:`BackgroundModel.foreground` for one image size (H, W), kept between
    frames so that a frame's image-sized steps write into memory already in use rather than asking the
    allocator for ~10 MB a frame (which it hands back to the system and page-faults in again)."""

    def __init__(self, shape: tuple[int, ...]) -> None:
        h, w = shape
        self.img = np.empty((h, w, 3), np.float32)  # the frame
        self.bg = np.empty((h, w, 3), np.float32)  # the background under the frame's light
        self.diff = np.empty((h, w, 3), np.float32)  # frame − background
        self.product = np.empty((h, w, 3), np.float32)  # per-channel products before they are summed
        self.dd = np.empty((h, w), np.float32)  # |I − B|², then the colour distortion
        self.db = np.empty((h, w), np.float32)
        self.bb = np.empty((h, w), np.float32)
        self.alpha = np.empty((h, w), np.float32)
        self.work = np.empty((h, w), np.float32)
        self.fg = np.empty((h, w), bool)
        self.shadow = np.empty((h, w), bool)
        self.test = np.empty((h, w), bool)
        self.mask = np.empty((h, w), np.uint8)
        self.opened = np.empty((h, w), np.uint8)


def _insert_sorted(stack: list[np.ndarray], x: np.ndarray) -> None:
    """Put ``x`` into ``stack``, a list of same-shaped arrays sorted elementwise (stack[0] ≤ stack[1]
    ≤ …), keeping it sorted: one pass of compare-and-swap, len(stack) min/max pairs."""
    carry = x
    for i, s in enumerate(stack):
        stack[i] = cv2.min(s, carry)
        carry = cv2.max(s, carry)
    stack.append(carry)
