"""``csv``: the BlendVOCA/SAiD coefficient CSV (:mod:`blendvoca.io.coeffs`), in the
rig's names, BlendVOCA's 32, or the columns of a naming convention of
:mod:`blendvoca.names` (in its order and spelling)."""

from __future__ import annotations

from blendvoca.export.align import AlignedTrack, align_track
from blendvoca.export.base import ExportFormat, ExportOptions
from blendvoca.io.coeffs import read_coeffs_csv, write_coeffs_csv
from blendvoca.names import BLENDVOCA_NAMES, convention


class CoeffsCsv(ExportFormat):
    """``csv``: BlendVOCA/SAiD CSV (rig, BlendVOCA or a convention's names)."""

    name, suffix, takes_convention = "csv", ".csv", True

    def write(self, out, coeffs, names, options: ExportOptions) -> AlignedTrack:
        if options.convention is not None:
            aligned = align_track(coeffs, names, options.convention, where="csv")
            write_coeffs_csv(out, aligned.coeffs, convention(options.convention).columns())
            return aligned
        target = options.rig.names if options.rig is not None else BLENDVOCA_NAMES
        aligned = align_track(coeffs, names, target, where="csv")
        write_coeffs_csv(out, aligned.coeffs, aligned.names)
        return aligned

    def read(self, path, *, fps: float):
        coeffs, names = read_coeffs_csv(path)
        return coeffs, names, fps
