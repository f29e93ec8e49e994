"""Writes the tables the Mitsuba import reads, from Mitsuba 3 itself, so that blockhash reads a
published scene as Mitsuba's RGB variants do without Mitsuba installed:

- ``blockhash/scene/mitsuba/cie1931_d65.csv``: the CIE 1931 2-degree colour matching
  functions and the CIE D65 illuminant at Mitsuba's nodes (every 5 nm from 360 to 830 nm), as
  Mitsuba's ``cie1931_xyz`` and ``cie_d65`` give them (they interpolate linearly between
  these nodes); :mod:`blockhash.scene.mitsuba.spectra` takes wavelength:value spectra to
  linear sRGB with them;
- ``blockhash/scene/mitsuba/conductors.csv``: the complex index of refraction (eta, k) in
  linear sRGB of each of Mitsuba's named conductor presets (``<string name="material"
  value="Au"/>``), as its ``conductor`` plugin loads them in ``scalar_rgb``.

usage: python tools/mitsuba_tables.py [--check]   (needs the extra blockhash[mitsuba];
--check compares both files with Mitsuba and writes nothing)
"""

from pathlib import Path

import numpy as np

from blockhash.studies.command import ToolParser

HERE = Path(__file__).resolve().parents[1] / "blockhash" / "scene" / "mitsuba"
CIE = HERE / "cie1931_d65.csv"
CONDUCTORS = HERE / "conductors.csv"
#: Mitsuba 3's conductor presets (its documentation's list, with the Palik variants).
PRESETS = ("a-C Ag Al AlAs AlAs_palik AlSb AlSb_palik Au Be Be_palik Cr CsI CsI_palik Cu "
           "Cu_palik Cu2O Cu2O_palik CuO CuO_palik d-C d-C_palik Hg Hg_palik HgTe HgTe_palik Ir "
           "Ir_palik K K_palik Li Li_palik MgO MgO_palik Mo Mo_palik Na_palik Nb Nb_palik "
           "Ni_palik Rh Rh_palik Se Se_palik SiC SiC_palik SnTe SnTe_palik Ta Ta_palik Te "
           "Te_palik ThF4 ThF4_palik TiC TiC_palik TiN TiN_palik TiO2 TiO2_palik VC VC_palik "
           "V_palik VN VN_palik W").split()


def _mi():
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    return mi


def cie_tables(wavelengths):
    mi = _mi()
    xyz = np.array([np.ravel(mi.cie1931_xyz(float(w))) for w in wavelengths])
    d65 = np.array([float(mi.cie_d65(float(w))) for w in wavelengths])
    return np.column_stack([wavelengths, xyz, d65])


def conductor_table():
    mi = _mi()
    rows = {}
    for name in PRESETS:
        p = mi.traverse(mi.load_dict({"type": "conductor", "material": name}))
        rows[name] = np.concatenate([np.ravel(p["eta.value"]), np.ravel(p["k.value"])])
    return rows


def check() -> int:
    from blockhash.scene.mitsuba.spectra import conductor_preset, tables

    w = np.arange(360.0, 830.5, 1.0)
    err = np.abs(tables(w) - cie_tables(w)[:, 1:]).max()
    print(f"CIE tables: largest difference from Mitsuba's functions at every 1 nm: {err:.3g}")
    worst = max(np.abs(np.concatenate(conductor_preset(n)) - v).max()
                for n, v in conductor_table().items())
    print(f"conductor presets: largest difference from Mitsuba's eta and k: {worst:.3g}")
    return 0 if err < 1e-5 and worst < 1e-5 else 1


def main(argv=None) -> int:
    p = ToolParser(__doc__, __file__)
    p.add_argument("--check", action="store_true",
                   help="compare both files with Mitsuba and write nothing")
    args = p.parse_args(argv)
    if args.check:
        return check()
    rows = cie_tables(np.arange(360.0, 830.5, 5.0))
    lines = ["# wavelength_nm,x_bar,y_bar,z_bar,d65 (CIE 1931 2-degree observer; CIE D65 as "
             "Mitsuba 3 scales it); written by tools/mitsuba_tables.py"]
    lines += [f"{w:g},{x:.9g},{y:.9g},{z:.9g},{d:.9g}" for w, x, y, z, d in rows]
    CIE.write_text("\n".join(lines) + "\n")
    table = conductor_table()
    lines = ["# name,eta_r,eta_g,eta_b,k_r,k_g,k_b (Mitsuba 3's conductor presets in linear "
             "sRGB); written by tools/mitsuba_tables.py"]
    lines += [name + "," + ",".join(f"{x:.9g}" for x in v) for name, v in table.items()]
    CONDUCTORS.write_text("\n".join(lines) + "\n")
    print(f"wrote {CIE} ({len(rows)} nodes) and {CONDUCTORS} ({len(table)} presets)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
