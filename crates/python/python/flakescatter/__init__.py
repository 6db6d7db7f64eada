"""flakescatter from Python: the angular reflectance of metallic (aluminium-flake)
coatings from flake orientations or confocal height maps, after NIST's ray models
(Sung et al., J. Coatings Technology 74, 2002), with numpy arrays in and out.

The functions are those of the Rust facade, one call each, with the command line's
conventions: angles in degrees (signed in-plane detector angles, ``theta_s = -theta_i``
is specular), lengths in micrometres, results as dicts of numpy arrays with the CLI's
column names. Errors are :class:`Error` and its subclasses :class:`InputError` and
:class:`FileFormatError` (both also ``ValueError``) and :class:`FileError` (also
``OSError``); warnings are :class:`FlakescatterWarning`. Long calls release the GIL and
stop with ``KeyboardInterrupt`` on Ctrl-C.

The submodule :mod:`flakescatter.mitsuba` (not imported here) renders a MERL table with
Mitsuba 3 and registers it as a Mitsuba BSDF; it needs the optional extra
``pip install flakescatter[render]``. The submodule :mod:`flakescatter.dask` (not
imported here either) runs the topographic models over Zarr stores and ``analyze`` over
many manifests on a Dask cluster; it needs ``pip install flakescatter[dask]``.
"""

from ._flakescatter import (
    Error,
    FileError,
    FileFormatError,
    FlakescatterWarning,
    InputError,
    InternalError,
    Map,
    __version__,
    compare,
    delta_e,
    distribution_model,
    distribution_mueller,
    fit,
    fit_paint,
    isotropic_model,
    localise_stack,
    orientation_stats,
    paint_brdf,
    read_brdf,
    read_map,
    segment,
    spectrum_to_lab,
    film,
    topographic_model,
    topographic_mueller,
    volume_model,
    write_map,
)

__all__ = [
    "Error",
    "FileError",
    "FileFormatError",
    "FlakescatterWarning",
    "InputError",
    "InternalError",
    "Map",
    "__version__",
    "compare",
    "delta_e",
    "distribution_model",
    "distribution_mueller",
    "fit",
    "fit_paint",
    "isotropic_model",
    "localise_stack",
    "orientation_stats",
    "paint_brdf",
    "read_brdf",
    "read_map",
    "segment",
    "spectrum_to_lab",
    "film",
    "topographic_model",
    "topographic_mueller",
    "volume_model",
    "write_map",
]
