"""The camera's shading points (:class:`ShadingPoints`): per sample, or per branch of a camera
ray split at glass or a coat, where it meets the surface it shades and what it carries there;
made by :mod:`.shading`, read by the direct light, the caustic and the indirect estimates."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ShadingPoints:
    """Per-pixel shading points, (h, w, ...) arrays.

    position : (h, w, 3) float32     world position
    normal : (h, w, 3) float32       unit shading normal
    view : (h, w, 3) float32         unit direction toward the viewer
    material : (h, w) int32          index into the material table, -1 for none
    weight : (h, w, 3) float32       path weight (1, or the product of mirror reflectances)
    owner : (h * w,) int64 or None   the camera sample each point belongs to, when a camera
                                     ray was split at glass (:meth:`gather`); None: point
                                     (i, j) is sample (i, j)
    samples : (h, w) or None         the camera samples' grid, with ``owner``
    escaped : (h, w) bool or None    the ray left the scene (material -1, ``view`` the
                                     opposite of its direction): it sees an environment
                                     light; None: none did
    rough_direct : (H, W, 3) float64 or None   per camera sample, the point, spot and
                                     directional lights' direct light met at the rough
                                     mirrors, glass and coats along its ray
                                     (:mod:`blockhash.frame.rough_direct`) and the lights
                                     met past its last specular event
                                     (:mod:`blockhash.frame.chain_end`), added to the
                                     direct layer by :meth:`gather_direct`; None: no ray met one
    first_hit : (h, w) bool or None  the point is its camera ray's first hit (the others: the
                                     reflections of a coated receiver's coat); None: every
                                     point whose ray's first hit is not specular is
    rough_pdf : (h, w) float64 or None   the density with which a rough vertex sent the ray
                                     that reached the point, over the ray's length squared
                                     (where it left the scene: the density itself; inf where
                                     no rough vertex sent it), for the weight of an area or
                                     environment light seen there against the vertex's own
                                     light samples (:mod:`blockhash.frame.rough_direct`);
                                     None: no ray left a rough vertex
    """

    position: np.ndarray
    normal: np.ndarray
    view: np.ndarray
    material: np.ndarray
    weight: np.ndarray
    owner: np.ndarray | None = None
    samples: tuple | None = None
    escaped: np.ndarray | None = None
    rough_direct: np.ndarray | None = None
    first_hit: np.ndarray | None = None
    rough_pdf: np.ndarray | None = None

    @property
    def shape(self) -> tuple[int, int]:
        return self.material.shape

    def gather_direct(self, image: np.ndarray) -> np.ndarray:
        """The direct layer's samples: :meth:`gather` of the per-point direct light
        ``image``, plus the light met at rough vertices (:attr:`rough_direct`)."""
        out = self.gather(image)
        if self.rough_direct is None:
            return out
        return (out + self.rough_direct.reshape(out.shape)).astype(np.asarray(out).dtype)

    def gather(self, image: np.ndarray) -> np.ndarray:
        """Per-point values (rows, cols, C) summed into the camera samples they belong to,
        (h, w, C) of :attr:`samples`: the identity unless a camera ray was split into
        several points (``owner``: each point's flat sample index, glass's two branches,
        :func:`blockhash.frame.shading.shading_points`)."""
        if self.owner is None:
            return image
        h, w = self.samples
        flat = np.asarray(image, dtype=np.float64).reshape(len(self.owner), -1)
        out = np.stack([np.bincount(self.owner, weights=flat[:, c], minlength=h * w)
                        for c in range(flat.shape[1])], axis=1)
        return out.reshape(h, w, *np.shape(image)[2:]).astype(np.asarray(image).dtype)
