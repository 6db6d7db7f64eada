"""Type stubs of the native module ``flakescatter._flakescatter``.

Conventions of every function: angles in **degrees** (as on the command line; in-plane
detector angles are signed, ``theta_s = -theta_i`` is the specular direction, positive
angles on the source side), lengths in **micrometres**, wavelengths in nanometres.
Results are dicts of numpy arrays named as the CLI's CSV columns (docs/cli.md); an
undefined value is NaN (an empty cell in the CLI's CSV).
"""

import os
from typing import Any, Literal, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

PathLike = Union[str, "os.PathLike[str]"]
Floats = Union[float, Sequence[float], npt.ArrayLike]
FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]
Stokes = Union[Literal["unpolarized", "s", "p"], Sequence[float]]

class Error(Exception):
    """Base class of the errors flakescatter raises."""

class InputError(Error, ValueError):
    """A parameter out of range or inconsistent with the others."""

class FileFormatError(Error, ValueError):
    """A file that was read but whose content is not usable (names file, line, field)."""

class FileError(Error, OSError):
    """A file that cannot be opened, read or written (``errno`` set where known)."""

class InternalError(Error):
    """A bug: the Rust code panicked."""

class FlakescatterWarning(UserWarning):
    """Warnings of the models and fits (undefined values, few tiles, poor fits)."""

class Map:
    """A height map: heights in µm on a regular grid with a validity mask.

    ``Map(heights_um, pitch_um, valid=None)``: ``heights_um`` of shape ``(ny, nx)`` in
    µm (NaN marks invalid points), ``pitch_um`` the pixel pitch ``(dx, dy)`` in µm (one
    number for square pixels), ``valid`` an optional boolean mask of the same shape.
    Row ``y``, column ``x``; ``x`` along columns.
    """

    def __init__(
        self,
        heights_um: npt.ArrayLike,
        pitch_um: Union[float, Tuple[float, float]],
        valid: Optional[npt.ArrayLike] = None,
    ) -> None: ...
    @property
    def heights_um(self) -> FloatArray:
        """Heights, µm, shape ``(ny, nx)``, float64, NaN where invalid (a copy)."""
    @property
    def valid(self) -> BoolArray:
        """Validity mask, shape ``(ny, nx)`` (a copy)."""
    @property
    def pitch_um(self) -> Tuple[float, float]:
        """Pixel pitch ``(dx, dy)``, µm."""
    @property
    def format(self) -> Optional[str]:
        """``"x3p"``, ``"sdf"`` or ``"text"`` when read from a file, else None."""
    @property
    def metadata(self) -> dict[str, str]:
        """The file's metadata (``format``, ``pitch_source``, ``x3p.*``, ...)."""
    @property
    def nx(self) -> int:
        """Number of columns (points along x)."""
    @property
    def ny(self) -> int:
        """Number of rows (points along y)."""
    @property
    def shape(self) -> Tuple[int, int]:
        """``(ny, nx)``."""
    @property
    def valid_count(self) -> int:
        """Number of valid points."""

def read_brdf(path: PathLike) -> dict[str, Any]:
    """A MERL isotropic BRDF table: ``brdf`` (3, 90, 90, 180) float64 in 1/sr indexed
    [R, G, B][theta_h bin][theta_d bin][phi_d bin], NaN where the file holds no value;
    ``channels``, ``scale``, ``file``."""

def read_map(
    path: PathLike,
    channel: Optional[Union[int, str]] = None,
    intensity: Optional[PathLike] = None,
    cutoff: Optional[float] = None,
    *,
    intensity_channel: Optional[Union[int, str]] = None,
    pixel_um: Optional[Union[float, Tuple[float, float]]] = None,
    z_unit: Optional[Literal["um", "nm", "m"]] = None,
    accept_md5_mismatch: bool = False,
) -> Map:
    """Read a height map (X3P, SDF, plain text or an instrument format; recognised from
    the content).

    ``intensity`` (a path) with ``cutoff`` (in the intensity file's stored values)
    masks points whose intensity is below the cutoff; ``intensity_channel`` instead
    uses a channel of the same file (PLU ``image0``, MetroPro ``intensity``, AL3D
    ``texture``, ...). ``channel`` and ``intensity_channel``: a 0-based index or a
    channel name (exact, else ignoring case when unique), as the CLI's ``--channel``
    and ``--intensity-channel``; a channel the file lacks is an InputError listing the
    file's channels. ``pixel_um`` (µm) and ``z_unit`` calibrate plain-text
    matrices, as the CLI's ``--pixel-um`` and ``--z-unit``.

    Raises FileError (missing file), FileFormatError (bad content), InputError.
    """

def write_map(map: Map, path: PathLike, format: Optional[Literal["x3p", "sdf", "text"]] = None) -> None:
    """Write a map as X3P (``.x3p``; heights in metres) or plain text (``.txt``; µm)."""

def segment(
    map: Map, *, z_step_um: float = 0.3, noise_um: float = 0.03, min_pixels: int = 100
) -> dict[str, npt.NDArray[Any]]:
    """Find the individual flakes of a height map (as ``flakescatter segment``).

    Returns the flake table as 1-D arrays, one entry per flake: ``x_um``, ``y_um``
    (centroid, µm), ``nx``, ``ny``, ``nz`` (unit normal), ``area_um2`` (true area, µm²),
    ``theta_n_deg``, ``phi_n_deg`` (degrees), ``projected_area_um2``,
    ``equivalent_diameter_um``, ``rms_um``, ``tilt_se_deg``, ``pixels``, ``inliers``
    (int64), ``touches_border`` (bool), ``quality`` (0..1). ``z_step_um`` and
    ``noise_um`` describe the instrument (µm); ``min_pixels`` >= 3.
    """

def orientation_stats(
    flakes: Union[PathLike, Mapping[str, npt.ArrayLike]], *, bin_deg: float = 1.0
) -> dict[str, Any]:
    """Area-weighted histogram of the flake tilt θn and its maximum-likelihood Gaussian
    width (as ``flakescatter stats --json``).

    ``flakes``: a flake-table CSV path or a dict with ``nx``, ``ny``, ``nz``,
    ``area_um2`` arrays (``segment()``'s result). ``bin_deg`` in [0.001, 45] degrees.
    Returns ``histogram`` (dict: ``theta_lo_deg``, ``theta_hi_deg``, ``area_fraction``,
    ``p_per_rad`` (1/rad), ``p_tilde``), ``hwhm_deg``, ``hwhm_ci95_deg`` (95 % interval,
    degrees; the upper end is inf at the uniform limit), ``hwhm_ci95_method``,
    ``sigma_deg``, ``effective_flakes``, ``flakes``, ``total_area_um2`` (µm²),
    ``column_set``, ``bin_deg``.
    """

def distribution_model(
    *,
    n: float = 1.5,
    hwhm: Optional[float] = None,
    sigma: Optional[float] = None,
    rms_tilt: Optional[float] = None,
    distribution: Optional[Union[PathLike, Mapping[str, npt.ArrayLike]]] = None,
    theta_i: Optional[Floats] = None,
    theta_s: Optional[Floats] = None,
    detectors: Optional[npt.ArrayLike] = None,
    aperture: float = 1.5,
    transmission: Literal["exact-unpolarized", "paper", "s", "p"] = "exact-unpolarized",
    weighting: Literal["physical", "paper-printed"] = "physical",
    clearcoat: bool = False,
    flake_index: Optional[Tuple[float, float]] = None,
    cone: Literal["exact", "constant"] = "exact",
    flake_stack: Optional[str] = None,
    flake_core: Optional[str] = None,
    wavelength_nm: Optional[float] = None,
) -> dict[str, FloatArray]:
    """The distribution model (as ``flakescatter model``).

    Orientation: a Gaussian p~ by one of ``hwhm``, ``sigma``, ``rms_tilt`` (degrees;
    hwhm 6 when none is given) or a tabulated ``distribution`` (histogram CSV path or a
    dict with ``theta_lo_deg``, ``theta_hi_deg``, ``area_fraction``). ``theta_i``
    (degrees, [0, 90); default 0, 30, 45, 60, 75), ``theta_s`` (degrees, (-90, 90);
    default -70 to 70 every 0.5) or ``detectors`` (an (m, 2) array of (theta_r_deg,
    phi_r_deg)), ``aperture`` (cone half-angle, degrees, [0, 20]; 0 = point
    detectors), ``n`` (clear-coat index >= 1), ``flake_index`` (N, K) or a perfect
    conductor.

    Returns one row per incidence × detector: ``theta_i_deg``, ``theta_s_deg``,
    ``phi_s_deg``, ``aperture_deg``, ``brdf_per_sr`` (1/sr), ``reflectance`` (fraction
    of the beam; NaN for point detectors), ``relative`` (to the same detector at the
    specular direction).
    """

def topographic_model(
    maps: Union[Map, Sequence[Map]],
    *,
    window: int = 5,
    tile_um: float = 32.0,
    n: float = 1.5,
    theta_i: Optional[Floats] = None,
    theta_s: Optional[Floats] = None,
    detectors: Optional[npt.ArrayLike] = None,
    aperture: float = 1.5,
    transmission: Literal["exact-unpolarized", "paper", "s", "p"] = "exact-unpolarized",
    weighting: Literal["physical", "paper-printed"] = "physical",
    clearcoat: bool = False,
    flake_index: Optional[Tuple[float, float]] = None,
    flake_stack: Optional[str] = None,
    flake_core: Optional[str] = None,
    wavelength_nm: Optional[float] = None,
    base_albedo: float = 0.0,
) -> dict[str, npt.NDArray[Any]]:
    """The topographic model over height maps, accumulated (as ``flakescatter topo``).

    Angles and optics as ``distribution_model``; ``window`` (odd >= 3 pixels) is the
    least-squares plane's window, ``tile_um`` (µm) the side of the tiles whose spread
    gives ``std_err``. Columns as ``distribution_model`` plus ``rays`` (int64) and
    ``std_err`` (1/sr; NaN where not estimable). ``base_albedo`` in [0, 1] (with
    ``flake_stack`` and no ``flake_core``) puts a Lambertian base under the flakes, as
    ``topo --base-albedo``: driven by the maps' pixel normals, scaled by the usable-pixel
    coverage, its standard error added to ``std_err`` (physics.md §13). Releases the
    GIL; Ctrl-C interrupts.
    """

def isotropic_model(
    maps: Union[Map, Sequence[Map]],
    *,
    node_spacing_deg: Optional[float] = None,
    window: int = 5,
    tile_um: float = 32.0,
    n: float = 1.5,
    theta_i: Optional[Floats] = None,
    theta_s: Optional[Floats] = None,
    detectors: Optional[npt.ArrayLike] = None,
    aperture: float = 1.5,
    transmission: Literal["exact-unpolarized", "paper", "s", "p"] = "exact-unpolarized",
    weighting: Literal["physical", "paper-printed"] = "physical",
    clearcoat: bool = False,
    flake_index: Optional[Tuple[float, float]] = None,
) -> dict[str, npt.NDArray[Any]]:
    """The topographic model averaged over the sample's rotation (physics.md §5.1).

    As ``topographic_model``; ``rays`` counts pixels whose ring meets the cone, and
    ``interpolation_error`` (reflectance units) is the tilt table's error estimate.
    ``node_spacing_deg`` (degrees) defaults to the aperture / 128.
    """

def distribution_mueller(
    *,
    incident: Optional[Stokes] = None,
    analyzer: Optional[Stokes] = None,
    n: float = 1.5,
    hwhm: Optional[float] = None,
    sigma: Optional[float] = None,
    rms_tilt: Optional[float] = None,
    distribution: Optional[Union[PathLike, Mapping[str, npt.ArrayLike]]] = None,
    theta_i: Optional[Floats] = None,
    theta_s: Optional[Floats] = None,
    detectors: Optional[npt.ArrayLike] = None,
    aperture: float = 1.5,
    weighting: Literal["physical", "paper-printed"] = "physical",
    clearcoat: bool = False,
    flake_index: Optional[Tuple[float, float]] = None,
    cone: Literal["exact", "constant"] = "exact",
) -> dict[str, FloatArray]:
    """Mueller matrices of the distribution model (physics.md §8, SCATMECH's bases).

    ``incident``: ``"unpolarized"`` (default), ``"s"``, ``"p"`` or a Stokes vector;
    ``analyzer``: None, ``"s"``, ``"p"`` or the fully polarised state it passes.
    Returns the angle columns, ``mueller_brdf_per_sr``, ``mueller_reflectance``,
    ``mueller_std_err`` (shape (rows, 4, 4), row-major, 1/sr or fraction),
    ``detected_brdf_per_sr``, ``detected_std_err`` (1/sr), ``relative``,
    ``dop_unpolarized``.
    """

def topographic_mueller(
    maps: Union[Map, Sequence[Map]],
    *,
    incident: Optional[Stokes] = None,
    analyzer: Optional[Stokes] = None,
    window: int = 5,
    tile_um: float = 32.0,
    n: float = 1.5,
    theta_i: Optional[Floats] = None,
    theta_s: Optional[Floats] = None,
    detectors: Optional[npt.ArrayLike] = None,
    aperture: float = 1.5,
    weighting: Literal["physical", "paper-printed"] = "physical",
    clearcoat: bool = False,
    flake_index: Optional[Tuple[float, float]] = None,
) -> dict[str, npt.NDArray[Any]]:
    """Mueller matrices of the topographic model (as ``distribution_mueller``, plus
    ``rays``). Releases the GIL; Ctrl-C interrupts."""

def volume_model(
    *,
    n: float = 1.5,
    hwhm: Optional[float] = None,
    sigma: Optional[float] = None,
    rms_tilt: Optional[float] = None,
    distribution: Optional[Union[PathLike, Mapping[str, npt.ArrayLike]]] = None,
    theta_i: Optional[Floats] = None,
    theta_s: Optional[Floats] = None,
    detectors: Optional[npt.ArrayLike] = None,
    aperture: float = 1.5,
    flake_index: Optional[Tuple[float, float]] = None,
    film_um: float = 38.0,
    diameter_um: float = 16.0,
    diameter_rel_sd: float = 0.25,
    thickness_um: float = 1.0,
    mass_fraction: Optional[float] = None,
    binder_density_g_cm3: float = 1.2,
    volume_fraction: Optional[float] = None,
    flakes: Optional[int] = None,
    depth_um: Optional[Tuple[float, float]] = None,
    tile_um: float = 1000.0,
    substrate: Literal["black", "specular", "lambertian"] = "black",
    substrate_albedo: float = 0.0,
    rims: Literal["absorb", "ignore", "diffuse"] = "absorb",
    rays: int = 1_000_000,
    seed: int = 1,
    max_events: int = 1000,
    min_weight: float = 1e-6,
    layers: int = 8,
    binder_absorption: float = 0.0,
    flake_stack: Optional[str] = None,
    flake_core: Optional[str] = None,
    wavelength_nm: Optional[float] = None,
) -> dict[str, Any]:
    """The volume model: a 3-D layer of cylinder flakes with multiple scattering.

    Lengths in µm; the amount is one of ``mass_fraction`` (default 0.05, with
    ``binder_density_g_cm3``), ``volume_fraction`` or ``flakes`` (a count). Every value
    is the mean over ``layers`` independent layers of the seed, the ``rays`` per
    incidence shared among them. Columns as ``topographic_model`` plus
    ``coat_brdf_per_sr``, ``single_bounce_brdf_per_sr``, ``single_bounce_std_err``,
    ``multiple_bounce_brdf_per_sr``, ``multiple_bounce_std_err`` (1/sr); ``std_err`` is
    the standard error over the layers (rays and layers; the rays only with
    ``layers=1``), ``ray_std_err`` and ``layer_std_err`` its two parts, ``ci95`` the
    half-width of the 95 % interval (Student's t on ``layers - 1`` degrees of freedom;
    NaN with one layer). Also ``energy`` (dict of per-incidence arrays: shares of the
    beam), ``layer`` (realised layers: counts summed, fractions averaged, with
    ``flakes_resized``, ``flakes_moved``, ``resized_area_fraction``),
    ``rays_per_incidence``, ``rays_per_layer``, ``layers``, ``seed``. A black
    ``substrate`` takes no ``substrate_albedo``. Interference flakes: ``flake_stack``
    (and ``flake_core``) at the one wavelength ``wavelength_nm`` (nm), as ``volume
    --flake-stack SPEC --flake-core M --wavelength NM``; a spectrum is a call per
    wavelength. Releases the GIL; Ctrl-C interrupts.
    """

def compare(
    measured: Union[PathLike, Mapping[str, npt.ArrayLike]],
    *,
    measured_kind: Literal["brdf", "reflectance-factor", "relative"] = "brdf",
    theta_i: Optional[Floats] = None,
    theta_s: Optional[Floats] = None,
    n: float = 1.5,
    hwhm: Optional[float] = None,
    sigma: Optional[float] = None,
    rms_tilt: Optional[float] = None,
    distribution: Optional[Union[PathLike, Mapping[str, npt.ArrayLike]]] = None,
    aperture: float = 1.5,
    transmission: Literal["exact-unpolarized", "paper", "s", "p"] = "exact-unpolarized",
    weighting: Literal["physical", "paper-printed"] = "physical",
    clearcoat: bool = True,
    flake_index: Optional[Tuple[float, float]] = None,
) -> dict[str, Any]:
    """A measured curve against the distribution model (as ``flakescatter compare``).

    ``measured``: CSV path or dict with ``theta_i_deg``, ``theta_s_deg``, ``value`` (and
    ``uncertainty``). ``theta_i``/``theta_s`` (degrees) select measured points. Returns
    ``points`` (dict of arrays: ``theta_i_deg``, ``theta_s_deg``, ``region``,
    ``measured``, ``model``, ``residual_log10``) and ``incidences`` (list of dicts:
    ``theta_i_deg``, ``scale``, ``regions``).
    """

def fit(
    measured: Union[PathLike, Mapping[str, npt.ArrayLike]],
    *,
    measured_kind: Literal["brdf", "reflectance-factor", "relative"] = "brdf",
    theta_i: Optional[Floats] = None,
    theta_s: Optional[Floats] = None,
    hwhm_start: float = 4.0,
    fit_n: bool = False,
    common_scale: bool = False,
    region: Tuple[float, float] = (5.0, 40.0),
    nonparametric: bool = False,
    bins: Optional[Floats] = None,
    lambda_: float = 0.05,
    n: float = 1.5,
    aperture: float = 1.5,
    transmission: Literal["exact-unpolarized", "paper", "s", "p"] = "exact-unpolarized",
    weighting: Literal["physical", "paper-printed"] = "physical",
    clearcoat: bool = True,
    flake_index: Optional[Tuple[float, float]] = None,
) -> dict[str, Any]:
    """Fit the orientation distribution to a measured curve (as ``flakescatter fit``).

    Gaussian (default): ``hwhm_deg``, ``hwhm_std_deg`` (degrees), ``n``, ``n_std``,
    ``scales``, ``chi2``, ``dof``, ``points``, ``iterations``, ``uncertainty_basis``,
    ``uncertainty_scale``, ``warnings``. ``nonparametric=True``: ``theta_lo_deg``,
    ``theta_hi_deg``, ``area_fraction``, ``p_tilde`` arrays on ``bins`` (edges,
    degrees), ``lambda``, ``points``, ``chi2_relative``. ``region``: aspecular range
    used, degrees.
    """

def fit_paint(
    measured: PathLike,
    *,
    family: Literal["auto", "gaussian", "trowbridge-reitz", "pearson-vii", "table"] = "auto",
    coverage: Optional[float] = None,
    n: float = 1.5,
    fit_n: bool = False,
    region: Tuple[float, float] = (2.0, 180.0),
    max_theta_r: Optional[float] = None,
    min_value: Optional[float] = None,
    haze: bool = True,
    smoothing: float = 0.01,
    flake_index: Optional[Tuple[float, float]] = None,
    flake_stack: Optional[str] = None,
    flake_core: Optional[str] = None,
    fit_thickness: Optional[Sequence[int]] = None,
    thickness_range_nm: Tuple[float, float] = (10.0, 600.0),
    flake_layers: Optional[int] = None,
    fit_flake_layers: bool = False,
    channel_band_nm: Optional[float] = None,
    fit_tint: bool = False,
) -> dict[str, Any]:
    """Fit a paint (clear coat, flakes, base) to a measured BRDF table (as
    ``flakescatter fit --paint``): one parameter set for every incidence, row and
    channel. Returns ``fit`` (the report: family and the other families' AIC/BIC,
    parameters with 95 % intervals, correlations, residual groups by incidence and
    region, warnings), ``params`` (the parameter file, for :func:`paint_brdf`),
    ``worst_ratio`` (worst group rms log10 / its target) and ``points`` (columns
    ``theta_i_deg``, ``theta_r_deg``, ``phi_r_deg``, ``channel``, ``measured``,
    ``model``). Angles in degrees, BRDFs in 1/sr. Interference flakes:
    ``flake_stack`` (``"TiO2:100/mica:400/TiO2:100"``) and ``flake_core`` as
    ``--flake-stack``/``--flake-core``, taken at each channel's wavelength;
    ``fit_thickness`` (layer numbers from 1, moved together) fits their thickness from
    the best point of a scan over ``thickness_range_nm`` (nm); the scan is in
    ``fit["thickness"]``. ``flake_layers`` (1-1000, free stacks only) piles the flakes
    that deep, as ``--flake-layers``; ``fit_flake_layers=True`` fits that number, as
    ``--fit-flake-layers``: the whole fit at every N from 1 to 16, the lowest chi2 kept,
    ``fit["flake_layers"]`` the N kept and ``fit["flake_layers_scan"]`` the ``layers``
    and ``chi2`` at each (``None`` where that fit failed). It needs a free stack
    (``flake_stack`` without ``flake_core``) and no ``flake_layers``; ``InputError``
    otherwise. ``channel_band_nm`` (interference flakes only, in (0, 400] nm) averages
    the flakes over a Gaussian band of that full width at half maximum about each
    channel's wavelength (``--channel-band``; physics.md §12.7). ``fit_tint=True``
    fits the binder's tint over the flakes too (per channel an optical depth, the
    ``tint <c>`` parameters; ``--fit-tint``, physics.md §12.9).
    """

def paint_brdf(
    params: Union[PathLike, Mapping[str, Any]],
    theta_i: Floats,
    theta_r: Floats,
    phi_r: Floats,
    *,
    aperture: float = 0.0,
) -> dict[str, npt.NDArray[np.float64]]:
    """A fitted paint's BRDF per channel (as ``flakescatter model --params``) at every
    incidence × detector ``(theta_r, phi_r)`` (degrees; ``phi_r = 0`` the specular
    half-plane), averaged over cones of half-angle ``aperture`` degrees. Returns
    ``theta_i_deg``, ``theta_r_deg``, ``phi_r_deg`` and ``brdf_<channel>_per_sr``."""

def spectrum_to_lab(
    wavelengths_nm: Floats,
    reflectance: npt.ArrayLike,
    *,
    illuminant: Literal["D65", "D50", "A"] = "D65",
    observer: Literal["2", "10"] = "10",
) -> dict[str, Any]:
    """CIE XYZ (Y = 100 for the perfect diffuser) and CIELAB of spectral reflectance
    factors (ASTM E308). ``reflectance``: one spectrum (1-D) or ``(spectra,
    wavelengths)``. Returns ``X``, ``Y``, ``Z``, ``L``, ``a``, ``b`` (floats or arrays
    of shape (spectra,)) and ``white_point``."""

def film(
    stack: str,
    *,
    theta_deg: Floats,
    wavelengths_nm: Floats,
    ambient: float = 1.5,
    substrate: Optional[str] = None,
) -> dict[str, Any]:
    """Amplitude and power reflection/transmission of a thin-film stack
    (``"TiO2:120/mica:400/TiO2:120"``, layers from the incidence side, thickness in nm)
    in a binder of index ``ambient``, free or on an opaque ``substrate``. Returns
    complex ``rs``, ``rp``, ``ts``, ``tp`` and float ``R_s``, ``R_p``, ``T_s``, ``T_p``
    of shape (wavelengths, angles), and ``stack``, ``theta_deg``, ``wavelengths_nm``.
    Conventions as the ``tmm`` package (physics.md section 13)."""

def delta_e(
    reference: npt.ArrayLike,
    sample: npt.ArrayLike,
    *,
    formula: Literal["2000", "ab", "94"] = "2000",
) -> Union[float, FloatArray]:
    """Colour difference of CIELAB colours (arrays of shape (..., 3)): CIEDE2000,
    ΔE*ab or ΔE*94."""

def localise_stack(
    path: PathLike,
    *,
    method: Literal["gaussian", "parabolic", "centroid", "argmax"] = "gaussian",
    fraction: float = 0.5,
    min_signal: float = 0.0,
    half_window: int = 3,
    saturation: Optional[float] = None,
    pixel_um: Optional[Tuple[float, float]] = None,
    z_step_um: Optional[float] = None,
    first_page: Optional[Literal["bottom", "top"]] = None,
) -> dict[str, Any]:
    """From a confocal z-stack (TIFF) to ``height`` (µm above the lowest slice),
    ``intensity`` (full scale 1) and ``width`` (peak FWHM, µm) ``Map``s, with
    ``report`` (pixel counts) and ``info`` (stack size, voxel sizes and sources).
    Releases the GIL; Ctrl-C interrupts."""

def _panic_for_test() -> None:
    """Raise InternalError through the boundary's panic handling (tests only)."""

class StoreRun:
    """A topographic run over Zarr v3 store(s) split into ranges of statistics tiles
    (what ``flakescatter.dask`` hands to workers). The keywords are those of
    ``topographic_model`` (``isotropic=False``) or ``isotropic_model``
    (``isotropic=True``), plus ``intensity_cutoff`` and ``intensity_store``."""

    def __init__(
        self,
        stores: Union[PathLike, Sequence[PathLike]],
        *,
        isotropic: bool = False,
        node_spacing_deg: Optional[float] = None,
        intensity_cutoff: Optional[float] = None,
        intensity_store: Optional[PathLike] = None,
        window: int = 5,
        tile_um: float = 32.0,
        n: float = 1.5,
        theta_i: Optional[npt.ArrayLike] = None,
        theta_s: Optional[npt.ArrayLike] = None,
        detectors: Optional[npt.ArrayLike] = None,
        aperture: float = 1.5,
        transmission: str = "exact-unpolarized",
        weighting: str = "physical",
        clearcoat: bool = False,
        flake_index: Optional[Tuple[float, float]] = None,
        flake_stack: Optional[str] = None,
        flake_core: Optional[str] = None,
        wavelength_nm: Optional[float] = None,
    ) -> None: ...
    def tile_count(self) -> int:
        """Statistics tiles of the stores (maps in order, each row-major)."""
    def trace(self, start: int, stop: int) -> dict[str, Any]:
        """The per-tile sums of tiles ``start..stop`` (plain values and numpy arrays)."""
    def finish(self, parts: list[dict[str, Any]]) -> dict[str, Any]:
        """The result dict of the whole run from its parts in tile order."""

def _sample_name(path: PathLike) -> str:
    """A manifest's sample name (``name`` key, else its file name)."""

def _comparison_table(rows: list[str]) -> Tuple[str, str, str]:
    """``(samples.csv, index.md, index.html)`` from ``summary.json`` ``comparison_row``s."""

def _check_sample_names(names: list[str], files: list[PathLike], reserved: list[str]) -> None:
    """Refuse sample names that cannot each have their own folder (``analyze``'s rule)."""
