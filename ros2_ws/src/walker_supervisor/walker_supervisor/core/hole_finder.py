"""Find a node's hole in a wrist camera's image: its offset from the gripper's axis, in metres.

The hole's mouth is a dark disc (the chamfer and the bore of a dark insert) of known radius in
a light face normal to the gripper's axis, at a known height below the gripper's contact point
(the face's height, from the kinematics). Seen by the camera of :mod:`walker_core.camera`, that
disc is a dark ellipse. The finder (OpenCV throughout: morphology, contours, ellipse fitting):

1. estimates the face's brightness around every pixel (a morphological closing wider than
   the hole, which fills a dark spot of the hole's size with the light around it), and marks
   the pixels much darker than their surroundings: darker by half, and by more than the noise
   (a shadow darkens the face and the hole alike, so a hole in a shadow stays darker than its
   shadowed face, and a shadow's edge is not a dark spot);
2. takes the outline of every marked region and fits an ellipse to it;
3. keeps the regions that are the hole's mouth as the camera would see it where the region
   is: the model's outline of the mouth there has the region's area within a tolerance, and
   the region fills its ellipse (a shadow or a part merged with it does not); a region that
   holds the mouth's disc but is not its shape is a mouth with something across it;
4. corrects the fitted centre for perspective (the centre of the projected circle is not the
   projection of its centre: the model's outline gives the difference) and carries it through
   the camera's line of sight to the face's plane.

It returns the hole's axis in the gripper's frame (x, y) [m] with its standard deviation, or
why it is not found: out of view (no dark disc, or one cut by the image's edge), occluded (a
dark region where the hole could be, but not the mouth's shape: a shadow edge or an object
across it), ambiguous (more than one mouth-shaped region).

Assumed, and not checked from the image: the gripper's axis is normal to the face (the
insertion's axis tolerance is 2 degrees) and the face's height below the gripper is known
(``height_uncertainty`` widens the answer's uncertainty by what it is off). A single
mouth-shaped region far larger than the mouth at that height (a node placed centimetres
higher than assumed: 15 mm nearer from 30 mm makes the mouth 2.8 times its area) is taken as
the mouth at the height its size says (:attr:`HoleMeasurement.height`): a point on the same
line of sight, which is what a look measures.
"""

from __future__ import annotations

import dataclasses
import enum
import math

import cv2
import numpy as np

from walker_core.camera import CameraModel

__all__ = ['Unseen', 'HoleMeasurement', 'HoleFinder']

_OUTLINE_POINTS = 64
# A region's area against the model's outline of the mouth where the region is: within this
# ratio either way (a chamfer made 1.5 to 2.5 mm across for the nominal 2 mm is within it), and
# the region filling its fitted ellipse at least this much.
_AREA_RATIO = 1.9
_FILL = 0.85
# A region of the mouth's area within this ratio either way that is not its shape: the mouth
# with something across it (larger regions are something else: a member, a shadow).
_MISSHAPEN = 3.0
# ... and that holds a disc of this fraction of the mouth's shorter half-axis (the mouth is in
# it, something else on it; a speck or a thin edge is not a hidden mouth).
_INSCRIBED = 0.8
# A region is the hole's when its pixels are darker than half their surroundings, and by this
# many noise deviations.
_DARKNESS = 0.5
_NOISE_MARGIN = 4.0
# [px] Quantisation floor of a centre fitted to a pixel outline.
_PIXEL_FLOOR = 0.05
# A mouth-shaped region larger than the mouth at the face's height given is the mouth nearer
# when, at the height its size says, its area is within this ratio of the model's, and that
# height is within these factors of the one given (a node placed centimetres high; a member or
# a shadow is no filled ellipse). Smaller ones are not taken: a speck would be a mouth far
# below, and a node lower than the area's tolerance allows is met by the descent's overtravel.
_RESIZED_RATIO = 1.3
_HEIGHT_FACTORS = (0.4, 1.0)


class Unseen(enum.StrEnum):
    """Why a hole was not found."""

    OUT_OF_VIEW = 'out of view'
    OCCLUDED = 'occluded'
    AMBIGUOUS = 'ambiguous'


@dataclasses.dataclass(frozen=True)
class HoleMeasurement:
    """What an image says about the hole under a gripper.

    Attributes
    ----------
    offset : ndarray, shape (2,), or None
        [m] Where the hole's axis is in the gripper's frame (x, y): how far the gripper must
        move in its own x-y plane to be over it. None when not found.
    sigma : float
        [m] Standard deviation of each component of ``offset`` (the larger of the two); inf
        when not found.
    pixel : tuple of 2 float, or None
        The mouth's centre in the image (u, v) [px], perspective-corrected.
    reason : Unseen or None
        Why it was not found; None when found.
    detail : str
        A sentence for a log: what was seen.
    height : float
        [m] The face's distance below the gripper that ``offset`` is at: the one given, or,
        for a mouth far nearer or farther than that, the one its size says (nan when not
        found). Either is a point on the same line of sight.
    """

    offset: np.ndarray | None
    sigma: float
    pixel: tuple[float, float] | None
    reason: Unseen | None
    detail: str
    height: float = math.nan

    @property
    def found(self) -> bool:
        """True when the image gave the hole's offset."""
        return self.reason is None


def _not_found(reason: Unseen, detail: str) -> HoleMeasurement:
    return HoleMeasurement(None, math.inf, None, reason, detail)


@dataclasses.dataclass(frozen=True)
class _Region:
    centre: tuple[float, float]
    area: float
    fill: float
    cut: bool
    outline: np.ndarray
    inscribed: float  # [px] radius of the largest disc inside the region


class HoleFinder:
    """Finds the hole's mouth in a wrist camera's image.

    Parameters
    ----------
    model : CameraModel
        The camera as the model knows it (nominal mount and intrinsics).
    mouth_radius : float
        [m] Radius of the hole's dark mouth on the face (the chamfer's,
        ``gripper.insertion_position_tolerance``).
    pixel_noise : float
        Standard deviation of the image's noise [grey levels of 255] the threshold stays above.
    """

    def __init__(self, model: CameraModel, mouth_radius: float, pixel_noise: float = 2.0
                 ) -> None:
        if not mouth_radius > 0.0:
            raise ValueError(f'the mouth radius must be positive, got {mouth_radius!r} m')
        self.model = model
        self.mouth_radius = float(mouth_radius)
        self.pixel_noise = float(pixel_noise)
        circle = np.linspace(0.0, 2.0 * math.pi, _OUTLINE_POINTS, endpoint=False)
        self._circle = np.column_stack([np.cos(circle), np.sin(circle), np.zeros_like(circle)])

    # ------------------------------------------------------------------ the model's outline
    def outline(self, hole_in_gripper) -> np.ndarray:
        """Return the mouth's outline in the image (n, 2) [px] of a hole at a point [m]."""
        return self.model.project(np.asarray(hole_in_gripper, dtype=float)
                                  + self.mouth_radius * self._circle)

    def _expected_area(self, hole_in_gripper) -> float:
        outline = self.outline(hole_in_gripper)
        if not np.all(np.isfinite(outline)):
            return math.nan
        return float(cv2.contourArea(outline.astype(np.float32)))

    def _minor_radius(self, hole_in_gripper) -> float:
        """[px] Half the shorter axis of the mouth's outline of a hole at a point [m]."""
        _, axes, _ = cv2.fitEllipse(self.outline(hole_in_gripper).astype(np.float32))
        return 0.5 * min(axes)

    def _perspective_shift(self, hole_in_gripper) -> np.ndarray:
        """Return the fitted centre less the projected one [px], of a hole at a point [m]."""
        outline = self.outline(hole_in_gripper).astype(np.float32)
        (u, v), _, _ = cv2.fitEllipse(outline)
        return np.array([u, v]) - self.model.project(hole_in_gripper)[0]

    # ------------------------------------------------------------------ the image
    def _dark_regions(self, image: np.ndarray, height: float) -> list[_Region]:
        grey = cv2.cvtColor(np.ascontiguousarray(image, dtype=np.uint8), cv2.COLOR_RGB2GRAY)
        grey = cv2.GaussianBlur(grey.astype(np.float32), (3, 3), 0.0)
        aim = np.array([0.0, 0.0, -height])
        diameter = max(2.0 * math.sqrt(max(self._expected_area(aim), 1.0) / math.pi), 3.0)
        size = int(2 * round(1.5 * diameter) + 1)
        kernel = cv2.getStructuringElement(cv2.MORPH_RECT, (size, size))
        surroundings = cv2.morphologyEx(grey, cv2.MORPH_CLOSE, kernel)
        dark = ((grey < _DARKNESS * surroundings)
                & (surroundings - grey > _NOISE_MARGIN * self.pixel_noise + 1.0))
        mask = cv2.morphologyEx(dark.astype(np.uint8), cv2.MORPH_OPEN,
                                cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (3, 3)))
        contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
        rows, columns = grey.shape
        inside = cv2.distanceTransform(mask, cv2.DIST_L2, 3)
        regions = []
        for contour in contours:
            if len(contour) < 6:
                continue
            points = contour.reshape(-1, 2).astype(np.float32)
            (u, v), (a, b), _ = cv2.fitEllipse(points)
            area = float(cv2.contourArea(contour)) + 0.5 * len(contour)  # to the pixels' edges
            ellipse_area = math.pi * 0.25 * (a + 1.0) * (b + 1.0)
            cut = bool(points[:, 0].min() <= 0 or points[:, 1].min() <= 0
                       or points[:, 0].max() >= columns - 1 or points[:, 1].max() >= rows - 1)
            x, y, w, h = cv2.boundingRect(contour)
            regions.append(_Region((u, v), area, area / ellipse_area if ellipse_area else 0.0,
                                   cut, points, float(inside[y:y + h, x:x + w].max())))
        return regions

    def _on_face(self, pixel, height: float) -> np.ndarray | None:
        point = self.model.on_plane(pixel, height)
        return None if point is None else point

    def find(self, image: np.ndarray, height: float, height_uncertainty: float = 0.0
             ) -> HoleMeasurement:
        """Find the hole in an RGB image.

        Parameters
        ----------
        image : ndarray, shape (height, width, 3), uint8
            The camera's frame, as the camera's model gives its size.
        height : float
            [m] The face's distance below the gripper's contact point (along its axis).
        height_uncertainty : float
            [m] Standard deviation of ``height``.

        Raises
        ------
        ValueError
            If the image is not the camera's size or the height is not positive.
        """
        image = np.asarray(image)
        expected = (self.model.height, self.model.width, 3)
        if image.shape != expected:
            raise ValueError(f'the image must be {expected}, got {image.shape}')
        if not height > 0.0:
            raise ValueError(f'the face must be below the gripper, got a height of {height!r} m')
        mouths, cut, misshapen, resized = [], [], [], []
        for region in self._dark_regions(image, height):
            hole = self._on_face(region.centre, height)
            if hole is None:
                continue
            expected_area = self._expected_area(hole)
            if not math.isfinite(expected_area) or expected_area <= 0.0:
                continue
            ratio = region.area / expected_area
            if region.cut:
                if ratio > 1.0 / (_AREA_RATIO * 4.0):
                    cut.append(region)
            elif 1.0 / _AREA_RATIO <= ratio <= _AREA_RATIO and region.fill >= _FILL:
                mouths.append(region)
            else:
                if region.fill >= _FILL and ratio > _AREA_RATIO:
                    other = self._height_of_size(region, height)
                    if other is not None:
                        resized.append((region, other))
                        continue
                if (1.0 / _MISSHAPEN <= ratio <= _MISSHAPEN
                        and region.inscribed >= _INSCRIBED * self._minor_radius(hole)):
                    misshapen.append((region, ratio))
        if not mouths and len(resized) == 1:
            region, other = resized[0]
            return self._measure(region, other, height_uncertainty, given=height)
        if len(mouths) > 1:
            where = ', '.join(f'({r.centre[0]:.0f}, {r.centre[1]:.0f})' for r in mouths)
            return _not_found(Unseen.AMBIGUOUS,
                              f'{len(mouths)} hole-shaped dark discs, at {where}')
        if not mouths:
            if misshapen:
                region, ratio = max(misshapen, key=lambda item: item[0].area)
                return _not_found(Unseen.OCCLUDED, (
                    f'a dark region at ({region.centre[0]:.0f}, {region.centre[1]:.0f}) of '
                    f"{ratio:.2f} times the mouth's area, filling {region.fill:.2f} of its "
                    "ellipse: not the mouth's shape"))
            if cut:
                return _not_found(Unseen.OUT_OF_VIEW, "a dark region cut by the image's edge")
            return _not_found(Unseen.OUT_OF_VIEW, "no dark disc of the mouth's size in view")
        return self._measure(mouths[0], height, height_uncertainty)

    def _height_of_size(self, region: _Region, height: float) -> float | None:
        """Return the face's height [m] at which a region is the mouth's size, or None.

        The mouth's image grows as the inverse square of its distance: from ``height``, the
        height is corrected by the square root of the area's ratio until the region is the
        mouth's size there (:data:`_RESIZED_RATIO`), within :data:`_HEIGHT_FACTORS` of
        ``height``.
        """
        low, high = _HEIGHT_FACTORS
        other = height
        for _ in range(8):
            hole = self._on_face(region.centre, other)
            if hole is None:
                return None
            expected = self._expected_area(hole)
            if not math.isfinite(expected) or expected <= 0.0:
                return None
            ratio = region.area / expected
            if abs(ratio - 1.0) < 0.01:
                break
            other /= math.sqrt(ratio)
            if not low * height <= other <= high * height:
                return None
        return other if 1.0 / _RESIZED_RATIO <= ratio <= _RESIZED_RATIO else None

    def _measure(self, region: _Region, height: float, height_uncertainty: float,
                 given: float | None = None) -> HoleMeasurement:
        """Measure the mouth of ``region`` on the face ``height`` [m] below the gripper.

        ``given``: the height the caller assumed, when the region's size put the face at
        ``height`` instead (said in the detail).
        """
        fitted = np.array(region.centre)
        hole = self._on_face(fitted, height)
        for _ in range(2):  # the shift varies slowly with where the hole is
            pixel = fitted - self._perspective_shift(hole)
            hole = self._on_face(pixel, height)
            if hole is None:
                return _not_found(Unseen.OUT_OF_VIEW, "the mouth's centre is not on the face")
        sigma_pixel = self._centre_sigma(region)
        step = [self._on_face(pixel + delta, height) for delta in ((1.0, 0.0), (0.0, 1.0))]
        jacobian = np.column_stack([step[0][:2] - hole[:2], step[1][:2] - hole[:2]])
        sigma = sigma_pixel * float(np.linalg.norm(jacobian, 2))
        if height_uncertainty > 0.0:
            lower = self._on_face(pixel, height + height_uncertainty)
            if lower is not None:
                sigma = math.hypot(sigma, float(np.linalg.norm(lower[:2] - hole[:2])))
        detail = f'mouth at ({pixel[0]:.1f}, {pixel[1]:.1f}) px, {region.area:.0f} px^2'
        if given is not None:
            detail += (f'; by its size the face is {height * 1e3:.1f} mm below the gripper, '
                       f'not {given * 1e3:.1f} mm')
        return HoleMeasurement(hole[:2].copy(), sigma, (float(pixel[0]), float(pixel[1])),
                               None, detail, float(height))

    @staticmethod
    def _centre_sigma(region: _Region) -> float:
        """[px] Standard deviation of a fitted centre: the outline's scatter about its ellipse."""
        (u, v), (a, b), angle = cv2.fitEllipse(region.outline)
        theta = math.radians(angle)
        d = region.outline - np.array([u, v], dtype=np.float32)
        x = d[:, 0] * math.cos(theta) + d[:, 1] * math.sin(theta)
        y = -d[:, 0] * math.sin(theta) + d[:, 1] * math.cos(theta)
        radial = np.hypot(x / max(0.5 * a, 1e-6), y / max(0.5 * b, 1e-6))
        scatter = float(np.std((radial - 1.0) * 0.25 * (a + b)))
        return math.hypot(scatter * math.sqrt(2.0 / len(region.outline)), _PIXEL_FLOOR)
