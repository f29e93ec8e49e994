"""The cover gather (blockhash/index/lookups/cover.py) uploaded to a GL context, for glsl/bh_cover.glsl.

Textures (wrapped rows, blockhash/gl/packing.py):

==============  ========  ==============================================================
texture         format    element
==============  ========  ==============================================================
cover records   RGBA32UI  2 texels per record: float32 bits of (x, y, z, h^2); words 3-5 of
                          Figure 4 (direction | normal, powers) and the photon's index
cover cells     RGBA32UI  cuckoo slot of a window: (key hi, key lo, first record, count)
==============  ========  ==============================================================
"""

from __future__ import annotations

import numpy as np

from blockhash.errors import CapacityError
from blockhash.gl.context import get_context
from blockhash.gl.limits import LOOP_LIMIT, is_llvmpipe
from blockhash.gl.packing import set_photon_box, upload
from blockhash.gl.pool import give_back
from blockhash.index.lookups.cover import MAX_OCTAVES


class GLCover:
    """A :class:`~blockhash.index.lookups.cover.CoverGather` in one GL context."""

    def __init__(self, gather, *, backend: str | None = None):
        self.gather = gather
        self.ctx = get_context(backend)
        with self.ctx:
            records = gather.records if len(gather) else np.zeros((1, 8), np.uint32)
            self.records, self.rec_w = upload(self.ctx, records.reshape(-1, 4), 4, "cover record",
                                              pooled=True)
            try:
                self.cells, self.cell_w = upload(self.ctx, gather.slots, 4, "cover cell",
                                                 pooled=True)
            except CapacityError:
                give_back(self.records)
                raise

    def check(self) -> None:
        """CapacityError on llvmpipe when a query could reach its loop limit (and silently
        lose photons there)."""
        need = self.gather.loop_bound()
        if is_llvmpipe(self.ctx) and need > LOOP_LIMIT:
            raise CapacityError(
                f"the cover gather may run up to {need:,} shader loop iterations per shading "
                f"point (its fullest windows hold {int(self.gather.max_count.max()):,} photons: "
                f"photons piled at one place), above llvmpipe's {LOOP_LIMIT:,} (beyond it "
                "llvmpipe silently stops the loops and photons go missing); render with "
                "method='cpu', or on a GPU driver")

    def defines(self, *, fetch_only: bool = False) -> dict:
        return {"BH_COVER": 1, "BH_CELLS": 0, "BH_COVER_REC_W": self.rec_w,
                "BH_COVER_CELL_W": self.cell_w, "BH_COVER_MASK": self.gather.buckets - 1,
                "BH_COVER_MAX_OCTAVES": MAX_OCTAVES, "BH_COVER_FINE_AXIS": self.gather.axis,
                "BH_FETCH_ONLY": int(fetch_only)}

    def textures(self) -> dict:
        return {"bh_cover_records": self.records, "bh_cover_cells": self.cells}

    def set_uniforms(self, program) -> None:
        """The photon box, the power scale and the octaves, as exact float32 and uint values."""
        g = self.gather
        set_photon_box(program, g.quantizer, g.power_scale)
        octaves = g.octave_uniforms()
        program["bh_cover_octaves"].value = len(octaves)
        if len(octaves):
            rows = program["bh_cover_octave"].array_length  # as the driver reports the array
            padded = np.zeros((max(rows, len(octaves)), 4), dtype=np.int64)
            padded[:len(octaves)] = octaves
            program["bh_cover_octave"].write(padded[:rows].astype(np.uint32).tobytes())

    def release(self) -> None:
        """Hand the textures back to the context's pool (:mod:`blockhash.gl.pool`)."""
        with self.ctx:
            give_back(self.records)
            give_back(self.cells)
