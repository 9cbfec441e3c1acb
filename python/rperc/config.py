"""The typed configs of rperc, generated from the Rust structs that define them
(``python -m rperc._codegen``; do not edit by hand).

Each is a frozen dataclass: ``replace(**changes)`` gives a changed copy,
``to_dict()``/``from_dict()`` convert to and from plain dicts (JSON), and the owning
Rust crate checks every value when one is made. Each ``...Overrides`` is the
``TypedDict`` of the config's fields, for typed keyword arguments."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar, Literal, TypedDict

from rperc._config_base import Config

__all__ = [
    "Ackermann",
    "AckermannOverrides",
    "AppearanceParams",
    "AppearanceParamsOverrides",
    "CameraMount",
    "CameraMountOverrides",
    "CeilingCameraConfig",
    "CeilingCameraConfigOverrides",
    "CeilingConfig",
    "CeilingConfigOverrides",
    "CeilingRenderConfig",
    "CeilingRenderConfigOverrides",
    "ColorDynamics",
    "ColorDynamicsOverrides",
    "ColorHistogramConfig",
    "ColorHistogramConfigOverrides",
    "ColorShapeConfig",
    "ColorShapeConfigOverrides",
    "ColorTemplateConfig",
    "ColorTemplateConfigOverrides",
    "FilterParams",
    "FilterParamsOverrides",
    "IcpConfig",
    "IcpConfigOverrides",
    "KeyImageParams",
    "KeyImageParamsOverrides",
    "LaserConfig",
    "LaserConfigOverrides",
    "LearnConfig",
    "LearnConfigOverrides",
    "LocalMapConfig",
    "LocalMapConfigOverrides",
    "LocaliserParams",
    "LocaliserParamsOverrides",
    "LoopConfig",
    "LoopConfigOverrides",
    "MonobotConfig",
    "MonobotConfigOverrides",
    "MosaicParams",
    "MosaicParamsOverrides",
    "MotionModel",
    "OdometryNoise",
    "OdometryNoiseOverrides",
    "ParticleColorConfig",
    "ParticleColorConfigOverrides",
    "PatternConfig",
    "PatternConfigOverrides",
    "PatternModelConfig",
    "PatternModelConfigOverrides",
    "PatternSequenceConfig",
    "PatternSequenceConfigOverrides",
    "PlanarConfig",
    "PlanarConfigOverrides",
    "ProposalParams",
    "ProposalParamsOverrides",
    "ReplayConfig",
    "ReplayConfigOverrides",
    "ScanConfig",
    "ScanConfigOverrides",
    "ScanParams",
    "ScanParamsOverrides",
    "SensorBias",
    "SensorBiasOverrides",
    "ServoParams",
    "ServoParamsOverrides",
    "SimConfig",
    "SimConfigOverrides",
    "SmootherConfig",
    "SmootherConfigOverrides",
    "Unicycle",
    "UnicycleOverrides",
    "WallConfig",
    "WallConfigOverrides",
]


@dataclass(frozen=True, kw_only=True)
class MotionModel(Config):
    """Which vehicle moves the robot, with its parameters; spelled in configs as `{"unicycle":
    {...}}` or `{"ackermann": {...}}`."""

    _union: ClassVar[bool] = True


@dataclass(frozen=True, kw_only=True)
class Unicycle(MotionModel):
    """Speed and turn rate (MR.CLAM).

    Attributes:
        speed_variance: Variance of the speed command noise, m^2/s^2 (>= 0).
        turn_rate_variance: Variance of the turn-rate command noise, rad^2/s^2 (>= 0).
    """

    _tag: ClassVar[str] = "unicycle"
    speed_variance: float = 0.01
    turn_rate_variance: float = 0.01


class UnicycleOverrides(TypedDict, total=False):
    """The fields of :class:`Unicycle`, for keyword arguments."""

    speed_variance: float
    turn_rate_variance: float


@dataclass(frozen=True, kw_only=True)
class Ackermann(MotionModel):
    """Rear-wheel encoder speed and steering angle (Victoria Park).

    Attributes:
        wheel_base: Distance between the axles `L`, m (> 0; Victoria Park: 2.83).
        encoder_offset: Lateral offset `H` of the speed encoder (rear left wheel) from the
            rear axle centre, m (>= 0, < `wheel_base`; Victoria Park: 0.76).
        laser_forward: Laser position `a` ahead of the rear axle, m (Victoria Park: 3.78).
        laser_left: Laser position `b` left of the rear axle centre, m (Victoria Park:
            0.50).
        speed_variance: Variance of the encoder speed noise, m^2/s^2 (>= 0; published: 0.2).
        steering_variance: Variance of the steering angle noise, rad^2 (>= 0; published:
            0.025).
    """

    _tag: ClassVar[str] = "ackermann"
    wheel_base: float = 2.83
    encoder_offset: float = 0.76
    laser_forward: float = 3.78
    laser_left: float = 0.5
    speed_variance: float = 0.2
    steering_variance: float = 0.025


class AckermannOverrides(TypedDict, total=False):
    """The fields of :class:`Ackermann`, for keyword arguments."""

    wheel_base: float
    encoder_offset: float
    laser_forward: float
    laser_left: float
    speed_variance: float
    steering_variance: float


@dataclass(frozen=True, kw_only=True)
class AppearanceParams(Config):
    """The appearance part of a tracker's parameters: colour space, bins, model and its
    adaptation, and the gradient term. Defaults are the values tuned on OTB Girl + Couple.

    Attributes:
        color_space: Colour space of the histograms. Default [`ColorSpace::Hsv`] (best on
            OTB Girl + Couple; the seed's [`ColorSpace::Opponent`] scores lower there).
        bins: Bins per axis, 1..=64 each. Default `[8, 8, 4]` (finer chroma than intensity).
        model: Single or bimodal model. Default bimodal.
        upper_fraction: Fraction of the ellipse's rows in the upper part of a bimodal model,
            in (0, 1). Default 0.4.
        adaptation_rate: `a` of eq. (29), in [0, 1]: weight of the new candidate when
            adapting the model. Default 0.03. 0 disables adaptation.
        adaptation_threshold: Eq. (29) is applied only when the intersection eq. (28)
            exceeds this, in [0, 1]. Default 0.7.
        gradient_weight: Weight of Birchfield's perimeter-gradient term relative to the
            colour term, >= 0. Default 0.7. 0 skips the gradient computation entirely.
        lost_threshold: Below this intersection the target is reported lost, in [0, 1].
            Default 0.3.
    """

    color_space: Literal["rgb", "opponent", "rg", "hsv"] = "hsv"
    bins: tuple[int, int, int] = (8, 8, 4)
    model: Literal["single", "bimodal"] = "bimodal"
    upper_fraction: float = 0.4
    adaptation_rate: float = 0.03
    adaptation_threshold: float = 0.7
    gradient_weight: float = 0.7
    lost_threshold: float = 0.3


class AppearanceParamsOverrides(TypedDict, total=False):
    """The fields of :class:`AppearanceParams`, for keyword arguments."""

    color_space: Literal["rgb", "opponent", "rg", "hsv"]
    bins: tuple[int, int, int]
    model: Literal["single", "bimodal"]
    upper_fraction: float
    adaptation_rate: float
    adaptation_threshold: float
    gradient_weight: float
    lost_threshold: float


@dataclass(frozen=True, kw_only=True)
class ColorHistogramConfig(Config):
    """Parameters of a [`ColorHistogramTracker`]. The appearance defaults were tuned on OTB
    Girl and Couple; the search, lost and scale defaults added since were set on the seeded
    synthetic sequences and Couple only, with Girl held out.

    Attributes:
        appearance: Colour model, adaptation and gradient term.
        search_radius: Half-size of the square search window of centre positions when the
            target is still, in pixels. Default 10.
        velocity_gain: The window grows by this times the estimated speed (px per frame, an
            average of the last displacements), so fast motion stays inside it. Default 1.5;
            0 keeps it at `search_radius`.
        max_search_radius: Largest half-size of the window, whether grown by speed or while
            the target is lost (it doubles every lost frame), >= `search_radius`, <= 512.
            Default 60.
        lost_ratio: The target is lost when the intersection falls below this fraction of
            its running average over confident frames (as well as below
            `appearance.lost_threshold`), in [0, 1]. Default 0 (off): on the challenge
            sequences and Couple it froze the box on fast motion (0.6 gave 8 lost frames on
            fast-1, 7 of them caused by the freeze) and caught no loss the contrast test
            missed.
        lost_contrast: The target is lost when its foreground contrast (mean foreground
            probability inside the box minus that in the ring around it) falls below this,
            in [-1, 1]. Default 0.05.
        ring_weight: Weight of the foreground contrast against the background ring when the
            three scales compete, >= 0. Default 0.5; 0 leaves the scale to the intersection.
        scale_prior: Weight of the prior `(ln(s / s_confident))^2` that keeps the scale near
            its value at the last confident frame, >= 0. Default 20: a 4 % step then costs
            0.03 of a score range of 1 + `gradient_weight`, enough to stop the perimeter
            gradient from pulling the box out to a stronger edge around the target (a
            synthetic white ring 1.4-1.7x the target's radius: scale 1.27 with 2, 1.0 with
            20) while a target that doubles in 60 frames is still followed.
        scale_step: Relative scale step: each frame tries `s / (1 + step)`, `s`, `s * (1 +
            step)`. Default 0.04; 0 keeps the initial size.
        min_scale: Smallest scale relative to the initial box, > 0. Default 0.5.
        max_scale: Largest scale relative to the initial box, >= `min_scale`. Default 2.0.
        momentum: Constant-velocity prediction: the search is centred on `centre + momentum
            * (last displacement)`, momentum in [0, 1]. Default 0.5.
        pyramid: Search at half resolution first (a 2 x 2-averaged frame: a quarter of the
            positions, each a quarter of the pixels), then refine the best position over the
            4 x 4 full-resolution centres it stands for, at its scale. Used while both semi-
            axes are at least 8 pixels. Default `true`.
        parallel: Search the three scales in parallel with rayon (default `true`); results
            are the same either way.
    """

    _native: ClassVar[str] = "color_histogram"
    appearance: AppearanceParams = field(default_factory=AppearanceParams)
    search_radius: int = 10
    velocity_gain: float = 1.5
    max_search_radius: int = 60
    lost_ratio: float = 0.0
    lost_contrast: float = 0.05
    ring_weight: float = 0.5
    scale_prior: float = 20.0
    scale_step: float = 0.04
    min_scale: float = 0.5
    max_scale: float = 2.0
    momentum: float = 0.5
    pyramid: bool = True
    parallel: bool = True


class ColorHistogramConfigOverrides(TypedDict, total=False):
    """The fields of :class:`ColorHistogramConfig`, for keyword arguments."""

    appearance: AppearanceParams
    search_radius: int
    velocity_gain: float
    max_search_radius: int
    lost_ratio: float
    lost_contrast: float
    ring_weight: float
    scale_prior: float
    scale_step: float
    min_scale: float
    max_scale: float
    momentum: float
    pyramid: bool
    parallel: bool


@dataclass(frozen=True, kw_only=True)
class ColorDynamics(Config):
    """Process noise of the constant-velocity model, in colour units where each axis of the
    colour space spans [0, 1). `B` is diagonal, so `B B^T = diag(std^2)`: the velocity of
    each parameter performs a random walk with these standard deviations per frame, and the
    parameter itself gets the `*_std` jitter on top.

    Attributes:
        centroid_std: Std of the centroid per frame (each axis). Default 0.02 (a third of a
            16-bin cell).
        centroid_velocity_std: Std of the centroid velocity per frame. Default 0.01.
        spread_std: Std of each principal magnitude per frame. Default 0.005.
        spread_velocity_std: Std of the principal magnitudes' velocity per frame. Default
            0.002.
        angle_std: Std of the two axis angles per frame, radians. Default 0.05.
        angle_velocity_std: Std of the angles' velocity per frame, radians. Default 0.02.
    """

    centroid_std: float = 0.02
    centroid_velocity_std: float = 0.01
    spread_std: float = 0.005
    spread_velocity_std: float = 0.002
    angle_std: float = 0.05
    angle_velocity_std: float = 0.02


class ColorDynamicsOverrides(TypedDict, total=False):
    """The fields of :class:`ColorDynamics`, for keyword arguments."""

    centroid_std: float
    centroid_velocity_std: float
    spread_std: float
    spread_velocity_std: float
    angle_std: float
    angle_velocity_std: float


@dataclass(frozen=True, kw_only=True)
class FilterParams(Config):
    """Tuning of a [`ParticleFilter`].

    Attributes:
        resampler: Resampling scheme. Default [`Resampler::Systematic`].
        resample_below: When to resample. Default [`ResamplePolicy::Always`]. Spelled
            `resample_below` (an ESS fraction, or none for "always") in configs.
        chunk_size: Particles per parallel work item (default 64). Fixed, so the split of
            the work never depends on the thread count; large enough that a chunk's
            likelihood calls outweigh rayon's per-task cost.
        parallel: Weight particles in parallel with rayon (default `true`). Results are
            identical either way; the serial path is faster for cheap likelihoods or few
            particles.
    """

    resampler: Literal["multinomial", "systematic", "stratified", "residual"] = "systematic"
    resample_below: float | None = None
    chunk_size: int = 64
    parallel: bool = True


class FilterParamsOverrides(TypedDict, total=False):
    """The fields of :class:`FilterParams`, for keyword arguments."""

    resampler: Literal["multinomial", "systematic", "stratified", "residual"]
    resample_below: float | None
    chunk_size: int
    parallel: bool


@dataclass(frozen=True, kw_only=True)
class ColorShapeConfig(Config):
    """Parameters of a [`ColorShapeTracker`](super::ColorShapeTracker) (seed 000 section 3.3).

    Attributes:
        color_space: Colour space of the distribution: `rgb` or `opponent` (B-G, G-R,
            R+G+B), the seed's choice against specular highlights. Default opponent.
        bins: Histogram bins per axis of `H(n)`, 1..=64 each. Default 16 x 16 x 16.
        n_samples: Number of samples `N`. Default 100.
        dynamics: Process noise `B` of `s = A s' + B w`.
        sigma: `sigma` of the weight `exp(-rho^2 / (2 sigma^2))`. Default 0.3.
        mu: `mu_1, mu_2, mu_3` weighting `1 - Phi_affine`, `1 - Phi_area`, `1 - Phi_quality`
            in `rho`, each >= 0, not all zero. Default (1, 1, 0.5).
        area_momentum: `mu` of the area prediction `A_{t-1} + mu (A_{t-1} - A_{t-2})`, in
            [0, 1]. Default 0.5.
        hole_penalty: Drop of `Phi_quality` per hole: `Phi_quality = clamp(1 - k (1 - E), 0,
            1)` with `E` the blob's Euler number. Default 0.25.
        contour_points: Points on the snake, >= 8. Default 48.
        search: Edge search along each normal in the snake's first iteration, pixels,
            1..=64: also how far outside the predicted contour the target's blob may reach.
            Default 12.
        min_search: The snake's narrowest search, pixels (each iteration halves the search
            down to this), >= 1. Default 2.
        edge_tolerance: A snake point lies on an edge (for `Phi_affine`) within this many
            pixels. Default 1.5.
        deform: After the affine fit, each point of `r_t` may move this far along its normal
            to the nearest edge (then the moves are smoothed): how much a non-rigid target's
            outline may change shape per frame, pixels. 0 keeps `r_t` affine. Default 4 (set
            on seeds 10-14 of the clutter and 10-12 of the other experiments: 2 left a bulge
            into a distractor touching the first frames in the outline for good).
        deform_passes: Smoothing passes of those moves, (1, 2, 1) / 4 each. Default 2.
        background_ring: Ring of background, as a fraction of the target's box on each side,
            whose colours are left out of the reference cloud when at least as frequent
            there as inside the target; 0 keeps every colour. Default 0.5.
        velocity_gain: Image velocity smoothing: the contour's predicted motion is this
            fraction of the last displacement plus the rest of the previous prediction, in
            [0, 1]. Default 0.5.
        mix_fraction: Fraction of the samples drawn each frame around the colour
            distribution measured inside the last accepted contour (a mixture proposal, as
            in Isard & Blake's ICONDENSATION), in [0, 0.99]: where the shape barely
            constrains the colour, it keeps the set from drifting off the target's real
            colours. Default 0.1.
        split_ratio: A blob larger than this times the predicted area is split at its narrow
            necks (see `split_radius`), >= 1. Default 1.25.
        split_radius: The split opens the blob by this fraction of the target's disc-
            equivalent radius, cutting off parts thinner than twice that (a touching ring or
            bar of the target's colour), then grows the part over the prediction back; re-
            acquisition opens the whole segmentation by the same radius before comparing
            shapes. Default 0.3 (0.2 kept a bar a fifth of the target's width; chosen on
            seeds 10-19 of the clutter experiment).
        reacquire_area_ratio: While lost, a blob is a candidate target when its area is
            within this ratio of the last area (smaller over larger), in (0, 1]. Default
            0.3.
        stiffness: The snake's resistance to changing shape from one frame to the next: the
            affine fit's linear part is drawn towards the prediction's with this weight,
            relative to a whole contour's worth of edge points (a ridge penalty; the
            translation is free). Keeps a touching same-coloured object from stretching the
            contour in one frame. >= 0. Default 0.5.
        snake_iterations: Snake fit iterations, >= 1. Default 6.
        morphology_radius: Radius of the opening and closing that clean `S(n)`, pixels.
            Default 1.
        refine: Refine the best sample's contour on the image edges (seed 000 "contour
            updating"). Default true.
        refine_min_support: The refined contour replaces the best sample's only when at
            least this fraction of its points lie on the masked image edges: where the
            target's grey level matches the background, `grad I` has no edge and the
            sample's contour is kept. Default 0.5.
        pull_inside: After the refinement, contour points outside the best sample's blob
            move back to its nearest cell along their normal. Default true.
        edge_dilation: Dilation radius of `grad S` masking the image edges in the
            refinement. Default 2.
        canny: Canny thresholds (low, high) for the image edges `grad I`. Default (20, 50).
        sample_cells: The target's size on each sample's grid: a target whose disc-
            equivalent diameter is `d` pixels is segmented on every `floor(d /
            sample_cells)`-th pixel (at least every pixel). Bounds a sample's cost whatever
            the target's size; the refined contour is fitted on every pixel. >= 4. Default
            24.
        roi_margin: Window margin around the predicted contour, as a fraction of its size
            (plus the edge search). Default 0.1.
        cloud_points: Most reference colours kept in the cloud that samples warp. Default
            512.
        lost_below: The target is lost when the best sample's weight is below this. Default
            0.05.
        min_blob_overlap: The target is also lost when the refined contour and the best
            sample's blob overlap (intersection over union, on the sampling grid) less than
            this: the snake kept a shape the segmentation no longer supports. 0 never.
            Default 0.5.
        seed: Seed of the sampler.
        filter: Particle-filter settings. The default chunk of 16 samples gives several
            chunks to the thread pool for the default 100 samples, each costing a
            segmentation.
    """

    _native: ClassVar[str] = "color_shape"
    color_space: Literal["rgb", "opponent", "rg", "hsv"] = "opponent"
    bins: tuple[int, int, int] = (16, 16, 16)
    n_samples: int = 100
    dynamics: ColorDynamics = field(default_factory=ColorDynamics)
    sigma: float = 0.3
    mu: tuple[float, float, float] = (1.0, 1.0, 0.5)
    area_momentum: float = 0.5
    hole_penalty: float = 0.25
    contour_points: int = 48
    search: int = 12
    min_search: int = 2
    edge_tolerance: float = 1.5
    deform: int = 4
    deform_passes: int = 2
    background_ring: float = 0.5
    velocity_gain: float = 0.5
    mix_fraction: float = 0.1
    split_ratio: float = 1.25
    split_radius: float = 0.3
    reacquire_area_ratio: float = 0.3
    stiffness: float = 0.5
    snake_iterations: int = 6
    morphology_radius: int = 1
    refine: bool = True
    refine_min_support: float = 0.5
    pull_inside: bool = True
    edge_dilation: int = 2
    canny: tuple[float, float] = (20.0, 50.0)
    sample_cells: float = 24.0
    roi_margin: float = 0.1
    cloud_points: int = 512
    lost_below: float = 0.05
    min_blob_overlap: float = 0.5
    seed: int = 0
    filter: FilterParams = field(default_factory=lambda: FilterParams(chunk_size=16))


class ColorShapeConfigOverrides(TypedDict, total=False):
    """The fields of :class:`ColorShapeConfig`, for keyword arguments."""

    color_space: Literal["rgb", "opponent", "rg", "hsv"]
    bins: tuple[int, int, int]
    n_samples: int
    dynamics: ColorDynamics
    sigma: float
    mu: tuple[float, float, float]
    area_momentum: float
    hole_penalty: float
    contour_points: int
    search: int
    min_search: int
    edge_tolerance: float
    deform: int
    deform_passes: int
    background_ring: float
    velocity_gain: float
    mix_fraction: float
    split_ratio: float
    split_radius: float
    reacquire_area_ratio: float
    stiffness: float
    snake_iterations: int
    morphology_radius: int
    refine: bool
    refine_min_support: float
    pull_inside: bool
    edge_dilation: int
    canny: tuple[float, float]
    sample_cells: float
    roi_margin: float
    cloud_points: int
    lost_below: float
    min_blob_overlap: float
    seed: int
    filter: FilterParams


@dataclass(frozen=True, kw_only=True)
class ColorTemplateConfig(Config):
    """Parameters of a [`super::ColorTemplateTracker`]. Defaults chosen by leave-one-sequence-
    out over the ten dev OTB sequences (see the crate README).

    Attributes:
        template_size: Side in pixels of the square whose area the search window is
            resampled to (Staple's fixed area): bounds the cost of a frame whatever the
            target's size. Default 96, in 32..=256.
        cell_size: HOG cell side in patch pixels, in 2..=8. Default 4.
        padding: The search window is the target grown by `padding` times its mean side on
            each axis, in 0.2..=4. Default 1.
        learning_rate: Learning rate of the translation filter (running average of its
            numerator and denominator), in (0, 1]. Default 0.02.
        lambda_: Regulariser `lambda` of the correlation filters, > 0. Default 1e-3. Spelled
            `lambda_` in configs (`lambda` is a Python keyword).
        output_sigma_factor: Width of the Gaussian label as a fraction of the target's mean
            side (in cells), > 0. Default 1/16.
        color_space: Colour space of the foreground and background histograms. Default RGB.
        bins: Histogram bins per axis. Default 32 x 32 x 32.
        color_learning_rate: Learning rate of the colour histograms, in (0, 1]. Default
            0.04.
        inner_padding: The foreground histogram is learned inside the target shrunk by this
            times its mean side (its edges mix target and background), in [0, 0.45]. Default
            0.2.
        merge_factor: Weight of the colour response in the merged response map, in [0, 1]; 0
            is the template alone, 1 the colour alone. Default 0.2.
        n_scales: Scales sampled by the scale filter (odd, 3..=65). Default 17.
        scale_step: Ratio between neighbouring scale samples, in (1, 1.5]. Default 1.03.
        scale_learning_rate: Learning rate of the scale filter, in (0, 1]. Default 0.025.
        scale_sigma: Width of the scale filter's Gaussian label, in scale steps, > 0.
            Default 1.
        scale_model_area: Pixel area each scale sample is resampled to before HOG, in
            64..=4096. Default 512.
        min_scale: Smallest scale relative to the first box, in (0, 1]. Default 0.1.
        max_scale: Largest scale relative to the first box, >= 1. Default 10.
        lost_ratio: The target is lost when the merged response's peak falls below this
            fraction of its running level over tracked frames, in [0, 1]; 0 never reports a
            loss. Learning fades linearly from the level down to this threshold. Default
            0.6.
        lost_psr_ratio: The target is also lost when the template response's peak-to-
            sidelobe ratio falls below this fraction of its running level, in [0, 1]; 0
            turns the test off. Default 0.
        lost_color_ratio: The target is also lost when the colour score at the peak (the
            mean foreground probability over the box) falls below this fraction of its
            running level, in [0, 1]; 0 turns the test off. Default 0.75 (with
            `lost_level_decay`, chosen on the ten OTB dev sequences by
            `benchmarks/template_lost.py`: the best F1 of the flag against IoU-0 frames
            among the settings within 0.005 of the best mean AUC).
        lost_contrast_ratio: The target is also lost when the seed's colour contrast (the
            first frame's colour model's mean foreground probability over the box minus over
            the rest of the search window, in [-1, 1]) falls below this multiple of its mean
            over the first tracked frames, in [-1, 1]: catches a slow drift onto the
            background, which the other signals follow. `None` turns the test off. Default
            `None`: on its own, leave-one-sequence-out over the ten OTB dev sequences chose
            no setting of it that improved the flag's precision and recall at once (see the
            guide).
        found_contrast_ratio: Hysteresis of the contrast test: once lost, the target is
            found again only when the seed's colour contrast is back over this multiple of
            its warm-up mean (or `lost_contrast_ratio`, when higher), in [-1, 1]. Default
            0.5.
        refind_contrast_ratio: While lost, a window whose seed colour contrast reaches this
            multiple of its warm-up mean is the target again even when its peak or colour
            score is under its threshold (those levels are of the appearance just before the
            loss), in [0, 1]; `None` turns this off. Default 0.7: with the levels sinking
            slowly, a target back after a short occlusion is then taken up at once (the OTB
            dev sequences hardly tell 0.7, 0.8, 0.9 and off apart; figures:
            `docs/decisions.md`).
        lost_level_decay: Factor on the running levels per lost frame, in (0, 1]: below 1 a
            target that came back changed (turned, lit differently) is taken up again; 1
            holds it to its old levels. Default 0.995 (halves them in about 140 frames;
            chosen with `lost_color_ratio`): a long loss stays flagged instead of the sunk
            levels taking up the background after a few tens of frames.
        redetect_step: Re-detection: while lost, the search also covers windows centred
            `redetect_step` window sizes apart around the last position, in (0, 2]. Default
            0.75.
        redetect_radius: Re-detection: the grid of windows reaches this many steps each way
            (1: 3 x 3), in 0..=4; 0 searches only the last window. Default 1.
        redetect_ratio: Re-detection: a window away from the last position is taken when it
            passes the lost rule and its merged peak reaches this fraction of the running
            level, in [0, 1] (1: the full level; at most `lost_ratio`: the lost rule alone).
            Far away, another object of the same kind is likelier than the target. Default
            1.
        lost_motion: While lost, the box moves this fraction of the way to the last window's
            peak (without learning from it), in [0, 1]: 0 keeps it where the target was last
            seen (right behind an occluder), 1 follows the peak (right when the loss was a
            false alarm). Default 1.
    """

    _native: ClassVar[str] = "color_template"
    template_size: int = 96
    cell_size: int = 4
    padding: float = 1.0
    learning_rate: float = 0.02
    lambda_: float = 0.001
    output_sigma_factor: float = 0.0625
    color_space: Literal["rgb", "opponent", "rg", "hsv"] = "rgb"
    bins: tuple[int, int, int] = (32, 32, 32)
    color_learning_rate: float = 0.04
    inner_padding: float = 0.2
    merge_factor: float = 0.2
    n_scales: int = 17
    scale_step: float = 1.03
    scale_learning_rate: float = 0.025
    scale_sigma: float = 1.0
    scale_model_area: float = 512.0
    min_scale: float = 0.1
    max_scale: float = 10.0
    lost_ratio: float = 0.6
    lost_psr_ratio: float = 0.0
    lost_color_ratio: float = 0.75
    lost_contrast_ratio: float | None = None
    found_contrast_ratio: float = 0.5
    refind_contrast_ratio: float | None = 0.7
    lost_level_decay: float = 0.995
    redetect_step: float = 0.75
    redetect_radius: int = 1
    redetect_ratio: float = 1.0
    lost_motion: float = 1.0


class ColorTemplateConfigOverrides(TypedDict, total=False):
    """The fields of :class:`ColorTemplateConfig`, for keyword arguments."""

    template_size: int
    cell_size: int
    padding: float
    learning_rate: float
    lambda_: float
    output_sigma_factor: float
    color_space: Literal["rgb", "opponent", "rg", "hsv"]
    bins: tuple[int, int, int]
    color_learning_rate: float
    inner_padding: float
    merge_factor: float
    n_scales: int
    scale_step: float
    scale_learning_rate: float
    scale_sigma: float
    scale_model_area: float
    min_scale: float
    max_scale: float
    lost_ratio: float
    lost_psr_ratio: float
    lost_color_ratio: float
    lost_contrast_ratio: float | None
    found_contrast_ratio: float
    refind_contrast_ratio: float | None
    lost_level_decay: float
    redetect_step: float
    redetect_radius: int
    redetect_ratio: float
    lost_motion: float


@dataclass(frozen=True, kw_only=True)
class ParticleColorConfig(Config):
    """Parameters of a [`ParticleColorTracker`].

    Attributes:
        appearance: Colour model, adaptation and gradient term.
        n_particles: Number of particles, >= 1. Default 200.
        position_noise: Standard deviation of the per-frame random walk of the centre, as a
            fraction of the initial box's mean half-size. Default 0.25.
        scale_noise: Standard deviation of the per-frame random walk of the scale. Default
            0.02.
        sigma: `sigma` of the weight `exp(-rho^2 / (2 sigma^2))` (seed 000 section 3.3) with
            `rho = 1 - intersection` (+ the gradient term). Default 0.1.
        min_scale: Smallest scale relative to the initial box, > 0. Default 0.5.
        max_scale: Largest scale relative to the initial box. Default 2.0.
        mix_fraction: Share of the particles redrawn each frame around the best centre of a
            coarse local search (a mixture proposal), in [0, 0.99]. Default 0.1 (set on the
            fast challenge sequences and Couple); 0 is plain CONDENSATION.
        search_radius: Half-size in pixels of that search's window when the target is still.
            Default 10.
        velocity_gain: The window grows by this times the estimated speed (px per frame).
            Default 1.5.
        max_search_radius: Largest half-size of the window, >= `search_radius`, <= 512.
            Default 60.
        filter: Particle-filter settings (resampler, policy, chunking, parallelism).
    """

    _native: ClassVar[str] = "particle_color"
    appearance: AppearanceParams = field(default_factory=AppearanceParams)
    n_particles: int = 200
    position_noise: float = 0.25
    scale_noise: float = 0.02
    sigma: float = 0.1
    min_scale: float = 0.5
    max_scale: float = 2.0
    mix_fraction: float = 0.1
    search_radius: int = 10
    velocity_gain: float = 1.5
    max_search_radius: int = 60
    filter: FilterParams = field(default_factory=FilterParams)


class ParticleColorConfigOverrides(TypedDict, total=False):
    """The fields of :class:`ParticleColorConfig`, for keyword arguments."""

    appearance: AppearanceParams
    n_particles: int
    position_noise: float
    scale_noise: float
    sigma: float
    min_scale: float
    max_scale: float
    mix_fraction: float
    search_radius: int
    velocity_gain: float
    max_search_radius: int
    filter: FilterParams


@dataclass(frozen=True, kw_only=True)
class PatternModelConfig(Config):
    """Parameters of model building and of the observation model.

    Attributes:
        canny_low: Canny hysteresis thresholds on imageproc's Sobel magnitude scale.
        canny_high: See `canny_low`.
        approximation_epsilon: Douglas-Peucker tolerance of the contour approximation,
            pixels.
        min_contour_pixels: Contours shorter than this many edge pixels are dropped.
        point_spacing: Arc length between model points along the approximated contours,
            pixels.
        n_samples: `N_s`, grey-level samples per vector.
        delta: `delta`, the step between samples, pixels.
        blur_sigma: Gaussian blur (sigma, pixels) of the image the gradient and the vectors
            are sampled from; the scale space blurs a frame by `blur_sigma * s`.
        fit_lags: Lags `1..=fit_lags` the auto-correlation slope is fitted on.
        min_contrast: Points whose profile has a standard deviation below this (grey levels)
            are textureless and rejected.
        min_slope: Points whose auto-correlation slope `|W|` is below this are rejected
            (flat auto-correlation: the profile cannot locate the contour).
        max_points: At most this many model points are kept (evenly spread along the
            contours).
        deviation: The approximation `C~` of the auto-correlation whose inverse turns an
            inter-correlation into the deviation `lambda` (section 3.3). Default
            [`DeviationModel::Parabola`].
        sigma: `sigma` of the Gaussian `Omega_sigma(lambda)`, samples.
        occlusion_threshold: A point whose deviation `lambda` exceeds this (samples) is
            occluded.
        max_occluded_fraction: The largest fraction of points left out as occluded.
        scale_levels: Scales of the scale-space levels (each >= 1, increasing).
    """

    canny_low: float = 30.0
    canny_high: float = 60.0
    approximation_epsilon: float = 0.7
    min_contour_pixels: int = 6
    point_spacing: float = 4.0
    n_samples: int = 12
    delta: float = 1.0
    blur_sigma: float = 1.0
    fit_lags: int = 2
    min_contrast: float = 3.0
    min_slope: float = 0.02
    max_points: int = 200
    deviation: Literal["line", "parabola"] = "parabola"
    sigma: float = 1.0
    occlusion_threshold: float = 1.5
    max_occluded_fraction: float = 0.4
    scale_levels: tuple[float, ...] = (1.0, 1.25, 1.5, 1.75, 2.0, 2.5, 3.0)


class PatternModelConfigOverrides(TypedDict, total=False):
    """The fields of :class:`PatternModelConfig`, for keyword arguments."""

    canny_low: float
    canny_high: float
    approximation_epsilon: float
    min_contour_pixels: int
    point_spacing: float
    n_samples: int
    delta: float
    blur_sigma: float
    fit_lags: int
    min_contrast: float
    min_slope: float
    max_points: int
    deviation: Literal["line", "parabola"]
    sigma: float
    occlusion_threshold: float
    max_occluded_fraction: float
    scale_levels: tuple[float, ...]


@dataclass(frozen=True, kw_only=True)
class PatternConfig(Config):
    """Parameters of a [`PatternTracker`].

    Attributes:
        n_particles: `N_p`, the number of particles (section 4.1 uses 200), without the
            coarse layer (with it, `coarse_kept`).
        sigma: `sigma_v = (sigma_x, sigma_y, sigma_theta, sigma_s)` of the random walk of
            section 3.3, in pixels, pixels, radians and scale units. Default section 4.1's
            `(5, 5, 3 deg, 0.1)`.
        lost_occluded_fraction: The estimate is reported lost when more than this fraction
            of the model points is occluded at it (an all-black frame occludes every point).
            Default 0.6, above the 40 % of occlusion the likelihood tolerates.
        refine_steps: Rounds of the local refinement of the estimate (see
            [`PatternTracker::update`]); 0 (with no `newton_steps`) reports the seed's plain
            weighted mean. Default 2 (steps of `sigma` and `sigma / 2`), then Gauss-Newton.
        refine_first_step: The refinement's first step, in random-walk sigmas (halved each
            round). Default 1: the search then reaches two sigmas from the weighted mean.
        refined_particle: The refined state replaces the lightest particle, weighted by its
            likelihood, so that the next frame starts from it. Default `true`.
        second_look: A frame whose estimate scores below this fraction of the track's
            typical score gets a second CONDENSATION iteration (see
            [`PatternTracker::update`]); 0 never. Default 0.9.
        refine_fine_rounds: The last rounds of the refinement that weigh every model point;
            the earlier (coarse) ones weigh every other point, at half the cost. Default 0:
            both rounds are coarse, the Gauss-Newton steps place the peak on every point.
        newton_steps: Gauss-Newton iterations on eq. 6 after the coordinate rounds (parabola
            deviation only; see [`PatternTracker::update`]): each costs about three
            likelihoods where a round of the coordinate search costs twelve. 0 leaves the
            whole refinement to the coordinate search (6 rounds, the last 2 fine, were the
            default before). Default 3, at most 100.
        parallel_min_work: With `filter.parallel`, a frame is processed on the rayon pool
            only when the tracker's work, particles times model points, reaches this:
            handing a frame to the pool and back costs more than two cores save on small
            ones (figures: `docs/decisions.md`). 0: whenever `filter.parallel`. Default 100
            000. The numbers do not depend on it.
        coarse_particles: States screened a frame by the coarse layer (see
            [`PatternTracker::update`]), drawn from the prior predictive; its best
            `coarse_kept` become the particles weighed on the frame. 0: no coarse layer, the
            particles are the prior predictive's as in the seed. Default 500. A pattern
            under 16 coarse pixels across (80 frame pixels at the default factor) goes
            without the layer: its coarse profiles would not fit inside it.
        coarse_factor: How many times coarser the layer's level is than the frame (each of
            its pixels the mean of a `coarse_factor x coarse_factor` block). Default 5.
        coarse_points: Most model points the coarse layer weighs (spread over the fine
            model's). Default 64.
        coarse_kept: With the coarse layer, the filter holds this many particles (at most
            `n_particles`): the layer's best states, not the random walk's draws, so fewer
            do (200 without the layer: 8 of 10 sequences of 3-sigma steps strayed; 50 after
            it: none, seeds 0-9). Default 50.
        coarse_spread: The coarse layer's states are drawn with the random walk's spread
            times this. Default 2: steps of 3 sigma in all four parameters at once lie where
            the walk itself hardly draws.
        coarse_refined: The best this many states of the coarse layer are moved to their
            peak on the coarse level by Gauss-Newton before the fine layer weighs them.
            Default 4.
        motion: The motion model: the seed's similarity `(x, y, theta, s)` (default), or
            `homography`, the plane in perspective: the particles still search over the
            similarity, with the model seen through the last frame's projective rest, and
            the estimate is then refined by Gauss-Newton on the 8-dof homography (see
            [`PatternTracker::update`]).
        lost_gain_spread: The estimate is also lost when the gains of its unoccluded
            profiles (each profile's slope on its stored one, eq. 6's correlation times
            their contrast ratio) spread more than this: the median absolute deviation of
            their logarithms. The pattern under one gain gives them all alike; clutter where
            the pattern is hidden matches a third to a half of the profiles by chance (no
            more than `lost_occluded_fraction` occluded), each with its own gain. Default
            0.3, tuned on generated perspective sequences, seeds 0-9 (camera.png over
            grass.png, and the generated pair): every tracked frame, with gain 0.8-1.2 and
            up to 30 % occlusion, spread at most 0.22; every frame with the pattern hidden
            but one (0.24, of 40 per image pair) at least 0.36. In similarity mode the gains
            are read only on frames that score under `second_look` of the track's typical
            score (the frames that get a second look).
        pattern: Model building and observation model (sections 3.2-3.3).
        filter: Particle-filter settings (resampler, policy, chunking, parallelism). Default
            chunks of 50 particles.
    """

    _native: ClassVar[str] = "pattern"
    n_particles: int = 200
    sigma: tuple[float, float, float, float] = (5.0, 5.0, 0.05235987755982989, 0.1)
    lost_occluded_fraction: float = 0.6
    refine_steps: int = 2
    refine_first_step: float = 1.0
    refined_particle: bool = True
    second_look: float = 0.9
    refine_fine_rounds: int = 0
    newton_steps: int = 3
    parallel_min_work: int = 100000
    coarse_particles: int = 500
    coarse_factor: int = 5
    coarse_points: int = 64
    coarse_kept: int = 50
    coarse_spread: float = 2.0
    coarse_refined: int = 4
    motion: Literal["similarity", "homography"] = "similarity"
    lost_gain_spread: float = 0.3
    pattern: PatternModelConfig = field(default_factory=PatternModelConfig)
    filter: FilterParams = field(default_factory=lambda: FilterParams(chunk_size=50))


class PatternConfigOverrides(TypedDict, total=False):
    """The fields of :class:`PatternConfig`, for keyword arguments."""

    n_particles: int
    sigma: tuple[float, float, float, float]
    lost_occluded_fraction: float
    refine_steps: int
    refine_first_step: float
    refined_particle: bool
    second_look: float
    refine_fine_rounds: int
    newton_steps: int
    parallel_min_work: int
    coarse_particles: int
    coarse_factor: int
    coarse_points: int
    coarse_kept: int
    coarse_spread: float
    coarse_refined: int
    motion: Literal["similarity", "homography"]
    lost_gain_spread: float
    pattern: PatternModelConfig
    filter: FilterParams


@dataclass(frozen=True, kw_only=True)
class PatternSequenceConfig(Config):
    """How a sequence is generated.

    Attributes:
        n_frames: Frames, the first one at the identity pose included.
        width: Frame width, pixels.
        height: Frame height, pixels.
        sigma: The tracker's `sigma_v` (pixels, pixels, radians, scale): steps are drawn in
            its units. Default section 4.1's `(5, 5, 3 deg, 0.1)`.
        max_step_sigmas: Frame `k`'s step sweeps one component, `(k - 1) mod 4` (x, y,
            theta, s in turn), uniform in `[-K sigma, K sigma]` with this `K` (Fig. 8 sweeps
            to about 4), as Fig. 8 plots each component against its own truth.
        other_step_sigmas: The other components step uniformly in `[-k sigma, k sigma]` with
            this `k`.
        max_occlusion: Largest fraction of the patch hidden by an occluder (uniform per
            frame, from 0); the occluder is a band of background clutter over one side of
            the patch.
        gain: Gain `a` of the illumination change `g -> a g + b`, uniform in this range.
        offset: Offset `b`, uniform in this range (grey levels).
        noise: Standard deviation of the additive Gaussian noise, grey levels.
        background_speed: Background motion, pixels per frame (a random direction per
            sequence).
        scale_range: The scale stays in this range (a step that would leave it is
            reflected).
        seed: Seed of every random draw.
    """

    _native: ClassVar[str] = "pattern_sequence"
    n_frames: int = 60
    width: int = 640
    height: int = 480
    sigma: tuple[float, float, float, float] = (5.0, 5.0, 0.05235987755982989, 0.1)
    max_step_sigmas: float = 4.0
    other_step_sigmas: float = 0.5
    max_occlusion: float = 0.0
    gain: tuple[float, float] = (1.0, 1.0)
    offset: tuple[float, float] = (0.0, 0.0)
    noise: float = 2.0
    background_speed: float = 2.0
    scale_range: tuple[float, float] = (0.7, 1.5)
    seed: int = 0


class PatternSequenceConfigOverrides(TypedDict, total=False):
    """The fields of :class:`PatternSequenceConfig`, for keyword arguments."""

    n_frames: int
    width: int
    height: int
    sigma: tuple[float, float, float, float]
    max_step_sigmas: float
    other_step_sigmas: float
    max_occlusion: float
    gain: tuple[float, float]
    offset: tuple[float, float]
    noise: float
    background_speed: float
    scale_range: tuple[float, float]
    seed: int


@dataclass(frozen=True, kw_only=True)
class ScanConfig(Config):
    """How a scan becomes points.

    Attributes:
        min_range: Readings shorter than this are the robot itself or noise, m (>= 0).
        max_range_margin: Readings within this of the scan's maximum range are no-returns, m
            (>= 0).
        point_spacing: Kept points are this far apart along the scan, m (> 0), the beams'
            sweep at their ranges: a near wall gives many readings per centimetre and would
            outweigh everything else.
        normal_radius: A point's normal is fitted to the readings within this distance of it
            that are contiguous along the scan, m (> 0); at least three times the wider of
            the beams' sweep at the point's range and the gap to its nearer neighbour (a
            wall seen at a slant spreads its readings wider than the sweep). Chosen by
            leave-one-log-out over the corpus logs on seeds 10-14, among 0.2 and 0.35.
        normal_min_points: A normal needs at least this many readings (>= 3).
        max_flatness: The fit's smaller spread over its larger one must stay under this for
            the readings to count as a line (in (0, 1)): corners and clutter get no normal.
        max_gap: Two successive readings further apart than this are not contiguous, m (>
            0); at least as much as the normal's radius grows to (see `normal_radius`).
    """

    min_range: float = 0.05
    max_range_margin: float = 0.01
    point_spacing: float = 0.05
    normal_radius: float = 0.35
    normal_min_points: int = 4
    max_flatness: float = 0.05
    max_gap: float = 0.3


class ScanConfigOverrides(TypedDict, total=False):
    """The fields of :class:`ScanConfig`, for keyword arguments."""

    min_range: float
    max_range_margin: float
    point_spacing: float
    normal_radius: float
    normal_min_points: int
    max_flatness: float
    max_gap: float


@dataclass(frozen=True, kw_only=True)
class IcpConfig(Config):
    """Settings of [`match_scan`].

    Attributes:
        iterations: Gauss-Newton iterations at most (>= 1).
        max_distance: A point pairs with a map point at most this far away, m (> 0).
        sigma: Standard deviation of a point's distance to its line, m (> 0): range noise
            and the map's own thickness.
        angle_sigma: The beam's angular noise, rad (>= 0): a point at range `r` lies `r *
            angle_sigma` off its beam's nominal direction, so its distance to its line has
            variance `sigma^2 + (r * angle_sigma)^2` and far points weigh less. Default 0
            (off): leave-one-log-out by ATE chose 0 in every fold; it lowers the NEES and
            costs ATE where far walls carry the match (figures: `docs/decisions.md`).
        huber: Residuals beyond this many standard deviations are down-weighted (Huber), (>
            0).
        covariance_scale: The scan's covariance is inflated by this factor (>= 1) for the
            correlation of its residuals.
        min_inliers: A match with fewer paired points is refused (>= 3).
        independent_pairs: Beyond this many paired points (>= 1) the scan's information
            stops growing: `covariance_scale` is multiplied by `pairs / independent_pairs`.
            Chosen by leave-one-log-out over the nine corpus logs (see the laser guide).
        tolerance: Iterations stop when a step moves less than this, m or rad (> 0).
        max_normal_angle: A point pairs only with a map point whose normal is within this
            angle of its own, rad (in (0, pi]): near a corner the nearest map point often
            lies on the other wall, and its line would pull the pose askew.
    """

    iterations: int = 20
    max_distance: float = 0.3
    sigma: float = 0.03
    angle_sigma: float = 0.0
    huber: float = 2.0
    covariance_scale: float = 3.0
    min_inliers: int = 10
    independent_pairs: int = 70
    tolerance: float = 1e-05
    max_normal_angle: float = 0.5235987755982988


class IcpConfigOverrides(TypedDict, total=False):
    """The fields of :class:`IcpConfig`, for keyword arguments."""

    iterations: int
    max_distance: float
    sigma: float
    angle_sigma: float
    huber: float
    covariance_scale: float
    min_inliers: int
    independent_pairs: int
    tolerance: float
    max_normal_angle: float


@dataclass(frozen=True, kw_only=True)
class LocalMapConfig(Config):
    """Settings of the local map.

    Attributes:
        key_distance: A scan becomes a key scan when the robot has moved this far from the
            last one, m (> 0).
        key_angle: ... or turned this much, rad (> 0).
        key_scans: The local map holds the points of this many latest key scans (>= 1).
        cell: Cell of the map's grid, m (> 0; at least ICP's pairing distance).
        search_reach: Where the odometry prior's three-sigma reach (its position deviation
            plus its heading deviation at the scan's median range) exceeds this, m (> 0),
            ICP also starts from the best poses of a correlative search over that window (a
            robust start: ICP's basin is about its pairing distance).
        search_step: The search's translation step, m (> 0).
        search_starts: ICP starts from this many of the search's best poses (1..=64).
        search_share: The search runs only when ICP from the prior's mean was refused,
            paired less than this share of the scan's points on lines (in [0, 1]; 1 searches
            wherever the prior is loose), ...
        search_rms: ... or left its pairs this far from their lines, RMS, m (> 0; at least
            ICP's `max_distance`: never for this reason). A match that paired most of the
            scan but fits it worse than nearly every match of its log (the 99th percentile
            is 6-10 cm on the corpus) may have settled in a wrong basin. Default 0.08 m,
            chosen by leave-one-log-out over the nine corpus logs on seeds 10-19 (see
            `docs/decisions.md`); without it one odometry seed in ten (seed 5) lost the
            Freiburg campus.
    """

    key_distance: float = 0.3
    key_angle: float = 0.17453292519943295
    key_scans: int = 20
    cell: float = 0.3
    search_reach: float = 0.3
    search_step: float = 0.1
    search_starts: int = 4
    search_share: float = 0.5
    search_rms: float = 0.08


class LocalMapConfigOverrides(TypedDict, total=False):
    """The fields of :class:`LocalMapConfig`, for keyword arguments."""

    key_distance: float
    key_angle: float
    key_scans: int
    cell: float
    search_reach: float
    search_step: float
    search_starts: int
    search_share: float
    search_rms: float


@dataclass(frozen=True, kw_only=True)
class LoopConfig(Config):
    """Settings of the loop-closure search.

    Attributes:
        enabled: Whether to look for closures at all.
        min_path: A place is a candidate only after this much path since it, m (> 0).
        sigmas: The search window spans this many standard deviations of the current key
            scan's pose relative to the place (from the chain of the graph), (> 0).
        overlap: A place is a candidate when it may lie within this of the current key scan,
            m (> 0), the window's reach included: the scans of two poses this far apart
            still overlap.
        radius: The window's radius is at least this, m (> 0), ...
        max_radius: ... and at most this along any axis, m (>= radius).
        angle: The heading window is at least this, rad (> 0), ...
        max_angle: ... and at most this, rad (in [angle, pi]).
        submap_keys: Key scans on each side of the candidate that make its submap (>= 0).
        every_keys: A closure is tried at every this many key scans (>= 1), and at the next
            one while a closure waits for its confirmation.
        cooldown_keys: After a confirmed pair of closures, no closure is tried for this many
            key scans (>= 0): the place is closed, and each attempt costs a correlative
            search.
        coarse_step: Coarse search step in x and y, m (> 0).
        hit_distance: A point scores when within this of the submap, m (> 0).
        refine: Best coarse poses refined by ICP (>= 1).
        min_inlier_share: A closure pairs at least this share of the scan's points (in (0,
            1]).
        max_rms: ... with at most this RMS distance to their lines, m (> 0).
        min_information: ... and at least this information in its weakest direction (the
            smallest eigenvalue of the scan's information in m and rad units, > 0).
        agree_distance: Two closures confirm each other when their corrections agree within
            this, m (> 0), ...
        agree_angle: ... and this, rad (> 0).
        max_chi2: After each optimisation the closure with the largest squared error (by its
            own information) is removed while that error exceeds this (> 0): a closure that
            disagrees with the chain and the other closures is a wrong one.
        inflation: Each closure's covariance is multiplied by this (>= 1) in the graph: a
            confirmed closure joins it with the one that confirmed it, both matched against
            the same place's key scans, whose errors they share, and the next pairs at that
            place match much of the same submap again. Default 3, chosen by leave-one-log-
            out over the nine corpus logs on seeds 10-19 (see `docs/decisions.md`).
    """

    enabled: bool = True
    min_path: float = 8.0
    sigmas: float = 3.0
    overlap: float = 2.0
    radius: float = 0.5
    max_radius: float = 30.0
    angle: float = 0.08726646259971647
    max_angle: float = 0.5235987755982988
    submap_keys: int = 6
    every_keys: int = 3
    cooldown_keys: int = 10
    coarse_step: float = 0.15
    hit_distance: float = 0.15
    refine: int = 4
    min_inlier_share: float = 0.5
    max_rms: float = 0.06
    min_information: float = 1000.0
    agree_distance: float = 0.2
    agree_angle: float = 0.03490658503988659
    max_chi2: float = 50.0
    inflation: float = 3.0


class LoopConfigOverrides(TypedDict, total=False):
    """The fields of :class:`LoopConfig`, for keyword arguments."""

    enabled: bool
    min_path: float
    sigmas: float
    overlap: float
    radius: float
    max_radius: float
    angle: float
    max_angle: float
    submap_keys: int
    every_keys: int
    cooldown_keys: int
    coarse_step: float
    hit_distance: float
    refine: int
    min_inlier_share: float
    max_rms: float
    min_information: float
    agree_distance: float
    agree_angle: float
    max_chi2: float
    inflation: float


@dataclass(frozen=True, kw_only=True)
class WallConfig(Config):
    """Settings of the wall landmarks.

    Attributes:
        enabled: Whether key scans' walls become landmarks of the pose graph. Off by
            default: on the corpus logs they win on some and lose on others, raise fhw's
            robot NEES, and cost speed (`rperc bench laser --variants laser,laser-walls`;
            see `straightness`).
        sigma_range: Range noise of the extraction, m (>= 0).
        split_epsilon: The extraction splits where a reading is farther than this from the
            chord, m (> 0).
        min_length: Shorter walls are not used, m (> 0): a short segment is a door jamb or a
            piece of furniture as often as a wall.
        max_range: Readings farther than this make no wall, m (> 0): far away the beams are
            spread too thin for a line fit to tell a facade from the objects before it
            (without it, freiburg-campus's robot NEES mean was 22 on seeds 10-12).
        straightness: Each end of a seen wall lies off the ideal straight wall by this much,
            m (>= 0; `slam::wall::straightness_covariance`): added to the fit's covariance,
            which shrinks with the number of readings and would claim millimetres. With
            `every_path`, `min_length` and `max_range`, chosen on the nine corpus logs,
            seeds 10-12 (never the reported 0-2), among 0.05-0.4 m, 3-20 m, 1-2 m and 8 m to
            unlimited: the lowest geometric-mean ATE among the settings whose NEES mean is
            at most 6 on six logs. Left out in turn, each log's choice was this one or (0.4
            m, 20 m); held out, the walls won on four logs and lost on four, which is why
            they are off by default.
        gate: A sighting pairs with a wall inside this chi-square confidence (2 dof, in (0,
            1)) ...
        drift_offset: ... with the key pose's error relative to the wall taken as this
            offset, m, (> 0) ...
        drift_angle: ... and this angle, rad (> 0), ...
        max_gap: ... and when the gap between the seen segment and the wall's extent along
            the line is at most this, m (0 to 5, the lookup grid's cell).
        every_path: A sighting becomes a factor after this much path since the wall's last
            one, m (> 0).
        robust: The factors' robust kernel `phi` (dynamic covariance scaling, > 0): a wrong
            pairing fades out instead of bending the map.
    """

    enabled: bool = False
    sigma_range: float = 0.01
    split_epsilon: float = 0.05
    min_length: float = 1.0
    max_range: float = 12.0
    straightness: float = 0.2
    gate: float = 0.99
    drift_offset: float = 0.1
    drift_angle: float = 0.03
    max_gap: float = 1.0
    every_path: float = 10.0
    robust: float = 5.0


class WallConfigOverrides(TypedDict, total=False):
    """The fields of :class:`WallConfig`, for keyword arguments."""

    enabled: bool
    sigma_range: float
    split_epsilon: float
    min_length: float
    max_range: float
    straightness: float
    gate: float
    drift_offset: float
    drift_angle: float
    max_gap: float
    every_path: float
    robust: float


@dataclass(frozen=True, kw_only=True)
class LaserConfig(Config):
    """Every setting of a run.

    Attributes:
        scan: Scans to points.
        icp: Scan matching.
        local_map: The front end's local map.
        loops: Loop closures.
        walls: Walls as landmarks of the pose graph.
        motion: The odometry's control noise (the same model as the EKF's motion).
        initial_pose: The first scan's pose.
        graph_iterations: Gauss-Newton iterations of the pose graph at most (>= 1).
        graph_tolerance: ... stopped when a step moves no pose more than this, m or rad (>
            0).
        chain_inflation: The front end's motion covariances are multiplied by this in the
            pose graph's chain (>= 1): consecutive matches against one local map share its
            errors, so the chain drifts more than independent steps would. Chosen for
            consistency by leave-one-log-out over the corpus logs on seeds 10-12 (never the
            reported seeds 0-2): `benchmarks/laser_chain_inflation.py` prints each log's
            choice.
    """

    _native: ClassVar[str] = "laser"
    scan: ScanConfig = field(default_factory=ScanConfig)
    icp: IcpConfig = field(default_factory=IcpConfig)
    local_map: LocalMapConfig = field(default_factory=LocalMapConfig)
    loops: LoopConfig = field(default_factory=LoopConfig)
    walls: WallConfig = field(default_factory=WallConfig)
    motion: Unicycle = field(default_factory=Unicycle)
    initial_pose: tuple[float, float, float] = (0.0, 0.0, 0.0)
    graph_iterations: int = 10
    graph_tolerance: float = 1e-05
    chain_inflation: float = 1.5


class LaserConfigOverrides(TypedDict, total=False):
    """The fields of :class:`LaserConfig`, for keyword arguments."""

    scan: ScanConfig
    icp: IcpConfig
    local_map: LocalMapConfig
    loops: LoopConfig
    walls: WallConfig
    motion: Unicycle
    initial_pose: tuple[float, float, float]
    graph_iterations: int
    graph_tolerance: float
    chain_inflation: float


@dataclass(frozen=True, kw_only=True)
class MonobotConfig(Config):
    """The monobot experiment. Defaults are the paper's run (Figs. 4 to 6).

    Attributes:
        landmarks: Number of landmarks (>= 1), all at `landmark_position`.
        steps: Iterations after the first observation (paper: 100).
        start: Start and end of the sinusoidal trajectory (paper: -1 m).
        amplitude: How far the robot moves out and back: `x(t) = start + amplitude (1 -
            cos(2 pi t / steps)) / 2` (default 1 m).
        landmark_position: Where the landmarks are (paper: 1 m).
        initial_variance: Initial robot variance `P_r,0|0`, > 0 (default 1e-6 m^2: the
            paper's robot starts at a known -1 m; exactly 0 would leave `P` singular and the
            NEES undefined).
        plant_noise: Plant noise `V` (paper: proportional to the motion command; default 10
            %).
        measurement_noise: Landmark measurement noise `W` (paper: proportional to the
            distance; default 5 %). Distances are nominal: planned robot position to
            `landmark_position`.
        reference_noise: Noise of the reference observation `z_0` (anchor or external
            sensor), as a function of the robot's nominal distance to the origin (default 5
            %).
        noise_floor: Standard deviation added to proportional models, so that a robot at
            rest or next to a landmark still has some noise (default 1 mm).
    """

    _native: ClassVar[str] = "monobot"
    landmarks: int = 1
    steps: int = 100
    start: float = -1.0
    amplitude: float = 1.0
    landmark_position: float = 1.0
    initial_variance: float = 1e-06
    plant_noise: tuple[Literal["constant", "proportional"], float] = ("proportional", 0.1)
    measurement_noise: tuple[Literal["constant", "proportional"], float] = ("proportional", 0.05)
    reference_noise: tuple[Literal["constant", "proportional"], float] = ("proportional", 0.05)
    noise_floor: float = 0.001


class MonobotConfigOverrides(TypedDict, total=False):
    """The fields of :class:`MonobotConfig`, for keyword arguments."""

    landmarks: int
    steps: int
    start: float
    amplitude: float
    landmark_position: float
    initial_variance: float
    plant_noise: tuple[Literal["constant", "proportional"], float]
    measurement_noise: tuple[Literal["constant", "proportional"], float]
    reference_noise: tuple[Literal["constant", "proportional"], float]
    noise_floor: float


@dataclass(frozen=True, kw_only=True)
class SensorBias(Config):
    """The sensors' biases, removed from every input. Bearing: `b_measured = bearing_offset +
    bearing_scale * b`. Range: `r_measured = range_offset + range_scale * q`, `q` the range,
    or the depth `r cos(b)` when `range_is_depth`. Controls: `u_measured = u /
    control_scale`. The identity (the default) changes nothing.

    Attributes:
        range_offset: Range offset, m.
        range_scale: Range scale (> 0).
        range_is_depth: The sensor reports the depth `r cos(b)` instead of the range `r`.
        bearing_offset: Bearing offset, rad.
        bearing_scale: Bearing scale (> 0).
        control_scale: Factors applied to the two controls (> 0): the true control is the
            measured one times this.
    """

    range_offset: float = 0.0
    range_scale: float = 1.0
    range_is_depth: bool = False
    bearing_offset: float = 0.0
    bearing_scale: float = 1.0
    control_scale: tuple[float, float] = (1.0, 1.0)


class SensorBiasOverrides(TypedDict, total=False):
    """The fields of :class:`SensorBias`, for keyword arguments."""

    range_offset: float
    range_scale: float
    range_is_depth: bool
    bearing_offset: float
    bearing_scale: float
    control_scale: tuple[float, float]


@dataclass(frozen=True, kw_only=True)
class PlanarConfig(Config):
    """Settings of [`super::PlanarSlam`]. The seed's variants (anchor, external sensor,
    freezing) are fields and combine freely.

    Attributes:
        motion: The vehicle, with its control noise (eqs. 1, 5). The sensor sits at the
            robot's origin for the unicycle and at the laser mount for the Ackermann
            vehicle.
        range_variance: Range noise variance of a detection, m^2 (> 0).
        bearing_variance: Bearing noise variance of a detection, rad^2 (> 0).
        association: Pairing method.
        gate_confidence: Confidence of the chi-square gates (individual, joint, fix), in (0,
            1).
        candidate_sightings: Consistent sightings a new landmark needs before it enters the
            map (>= 1).
        candidate_window: A candidate not seen again within this many seconds is dropped (>
            0).
        jcbb_max_nodes: Joint-compatibility tests JCBB may make per scan before it settles
            for the best hypothesis found so far (>= 1).
        wall_overlap_gap: A seen wall segment and a map wall's extent, both on the wall's
            line, may be this far apart and still be paired, m (>= 0): collinear walls
            separated by more (two sides of a doorway) stay two walls.
        wall_admission_confidence: A wall detection outside the gate of every overlapping
            wall is new only when it is also outside this wider chi-square gate of each (in
            (0, 1), at least `gate_confidence`); in between it is refused. Set on the
            simulated room (`room::RoomConfig`), where at 0.9999 about one run in ten still
            duplicated a wall after an unlucky sighting (NIS 20).
        wall_max_angle_sd: A wall detection whose angle's standard deviation exceeds this is
            not used, rad (> 0): a line landmark's observation is curved in its angle, so a
            short wall seen with a loose angle (a door jamb 0.4 m long: about 6 degrees)
            biases every linearised update the same way and the filter turns overconfident.
            Set on a simulated 40 m corridor loop with door jambs, never on a laser log
            (`benchmarks/wall_corridor.py`; figures: `docs/decisions.md`).
        wall_shared_sd: The straightness error a detection shares with earlier detections of
            the same part of its wall, m (>= 0; 0: none): a wall's own bends stay where they
            are, so sightings of one stretch of it repeat their error instead of averaging
            it away. A detection paired with a wall gets
            [`crate::wall::straightness_covariance`] of this `sigma` times `sqrt(n)` added
            to its noise, `n` the wall's earlier paired detections covering more than half
            of the same stretch (the shorter one's), among its latest
            [`super::WALL_PARTS_KEPT`]. Its own covariance should already hold the floor
            once (`rperc.slam.wallslam` adds it to every sighting). `sqrt(n)` lies between
            independent sightings (no growth) and one error shared by all (`n`). Checked in
            a simulated corridor whose walls have bends of their own
            (`benchmarks/wall_corridor.py --bend 0.02`) and chosen on ACES with the floor
            `wallslam.STRAIGHTNESS`, Intel held out (`benchmarks/wall_fig7.py`); the
            detection that admits a wall is not counted (figures: `docs/decisions.md`).
        wall_innovation: Where a wall detection is compared with the map's wall (`segment`,
            the default, or seed 000's `line`).
        anchor: Eqs. (24)-(25): the first landmark becomes the global reference (a point, or
            a wall: then the robot's distance to it and heading are taken relative to it).
        external_fix: Eqs. (26)-(27): apply the xy fixes of an external sensor (otherwise
            they are counted and ignored).
        fix_lever_arm: Where the external sensor's point sits on the robot, m (forward, left
            of the pose's origin): a fix measures `t + R(theta) lever_arm` (Victoria Park's
            GPS is compared at the laser, 3.78 m ahead and 0.5 m left of the rear axle).
        freeze_after: Landmarks revised more than this many times leave the state (text
            under Fig. 7, where it is 50); `None` never freezes.
        freeze_mode: How a landmark is frozen.
        initial_pose: Start pose `(x, y, theta)`.
        initial_pose_variance: Variances of the start pose (>= 0; zero: a known start).
        compression: Whether to run the compressed EKF (a speed choice: the results are the
            same).
        active_radius: The compressed filter's active area when it is made: the landmarks
            within this distance of the sensor, m (> 0); any other landmark a scan may be
            paired with joins it when seen. The area is made afresh (one global update) when
            the work it costs over a fresh one has paid for a global update. A speed setting
            only: timed on Victoria Park from 1 to 50 m (0.68 to 0.97 s), the results
            identical.
        compression_min_landmarks: The compressed filter is used once the state holds at
            least this many landmarks (>= 1): below, a full update costs less than the
            compressed one's bookkeeping (Victoria Park's first 300 scans, 74 landmarks: 20
            ms full, 26 ms compressed; MR.CLAM's 15: 36 ms against 60 ms). A speed setting
            only.
        bias: Systematic sensor and odometry errors, removed from every detection and
            control before use (identity by default; MR.CLAM's are calibrated offline).
            `range_variance` and `bearing_variance` are the noise left after it.
        control_bias_sd: Unknown constant odometry biases estimated in the state, with these
            prior standard deviations: a relative error `s` of the first control and an
            offset `b` of the second, so that the true controls are `(u0 (1 - s), u1 - b)`
            (speed read long by `s`, turn rate off by `b` rad/s). `None`: no bias states
            (the robot block is `(x, y, theta)`); otherwise it is `(x, y, theta, s, b)`.
        first_estimates: First-estimates Jacobians (Huang, Mourikis & Roumeliotis 2008): a
            wall's observation is linearised at the wall's first estimate (the one it
            entered the map with), not its current one, and the robot's prediction at the
            pose it was first estimated at (its prediction, before the last update moved
            it). Then the linearised system keeps the translation and rotation of the whole
            map unobservable, as the nonlinear one is; linearised at changing estimates it
            gains information about them from nowhere, which makes the filter overconfident
            (tested: with it, the robot's absolute heading and position variances never fall
            below the start's). A point landmark's observation is linearised at the point's
            first estimate too (its position when admitted; the predicted detection stays at
            its current one). It made MR.CLAM robot 3 consistent; but a first estimate made
            while the robot was far off (robot 2 after a long stretch without a sighting)
            keeps Jacobians that no longer describe the map, and that run diverges (figures:
            `docs/decisions.md`).
    """

    _native: ClassVar[str] = "planar"
    motion: MotionModel = field(default_factory=Unicycle)
    range_variance: float = 0.01
    bearing_variance: float = 0.001
    association: Literal["known", "nn", "jcbb"] = "known"
    gate_confidence: float = 0.99
    candidate_sightings: int = 1
    candidate_window: float = 10.0
    jcbb_max_nodes: int = 20000
    wall_overlap_gap: float = 0.5
    wall_admission_confidence: float = 0.999999
    wall_max_angle_sd: float = 0.03490658503988659
    wall_shared_sd: float = 0.0
    wall_innovation: Literal["line", "segment"] = "segment"
    anchor: bool = False
    external_fix: bool = False
    fix_lever_arm: tuple[float, float] = (0.0, 0.0)
    freeze_after: int | None = None
    freeze_mode: Literal["marginalise", "consider"] = "marginalise"
    initial_pose: tuple[float, float, float] = (0.0, 0.0, 0.0)
    initial_pose_variance: tuple[float, float, float] = (0.0, 0.0, 0.0)
    compression: Literal["auto", "off"] = "auto"
    active_radius: float = 5.0
    compression_min_landmarks: int = 100
    bias: SensorBias = field(default_factory=SensorBias)
    control_bias_sd: tuple[float, float] | None = None
    first_estimates: bool = False


class PlanarConfigOverrides(TypedDict, total=False):
    """The fields of :class:`PlanarConfig`, for keyword arguments."""

    motion: MotionModel
    range_variance: float
    bearing_variance: float
    association: Literal["known", "nn", "jcbb"]
    gate_confidence: float
    candidate_sightings: int
    candidate_window: float
    jcbb_max_nodes: int
    wall_overlap_gap: float
    wall_admission_confidence: float
    wall_max_angle_sd: float
    wall_shared_sd: float
    wall_innovation: Literal["line", "segment"]
    anchor: bool
    external_fix: bool
    fix_lever_arm: tuple[float, float]
    freeze_after: int | None
    freeze_mode: Literal["marginalise", "consider"]
    initial_pose: tuple[float, float, float]
    initial_pose_variance: tuple[float, float, float]
    compression: Literal["auto", "off"]
    active_radius: float
    compression_min_landmarks: int
    bias: SensorBias
    control_bias_sd: tuple[float, float] | None
    first_estimates: bool


@dataclass(frozen=True, kw_only=True)
class SimConfig(Config):
    """The simulated world and its noise (the truth uses the same variances as the filter's
    [`PlanarConfig`] built by [`SimConfig::slam_config`]).

    Attributes:
        radius: Radius of the circle the robot drives, m.
        speed: Forward speed, m/s.
        dt: Time between controls (and scans), s.
        steps: Number of control steps.
        landmarks: Landmarks on two rings, `radius - ring_gap` and `radius + ring_gap`.
        ring_gap: Half the distance between the landmark rings, m.
        max_range: Sensor range, m.
        speed_variance: Speed noise variance per step, m^2/s^2.
        turn_rate_variance: Turn-rate noise variance per step, rad^2/s^2.
        range_variance: Range noise variance, m^2.
        bearing_variance: Bearing noise variance, rad^2.
        initial_pose_variance: Start pose variances (the true start is drawn from them).
        fix_every: An external xy fix every this many steps (`None`: no fixes).
        fix_variance: Variance of each fix coordinate, m^2.
    """

    _native: ClassVar[str] = "planar_sim"
    radius: float = 10.0
    speed: float = 1.0
    dt: float = 0.1
    steps: int = 600
    landmarks: int = 24
    ring_gap: float = 3.0
    max_range: float = 6.0
    speed_variance: float = 0.01
    turn_rate_variance: float = 0.001
    range_variance: float = 0.01
    bearing_variance: float = 0.0001
    initial_pose_variance: tuple[float, float, float] = (0.0001, 0.0001, 1e-05)
    fix_every: int | None = None
    fix_variance: float = 0.01


class SimConfigOverrides(TypedDict, total=False):
    """The fields of :class:`SimConfig`, for keyword arguments."""

    radius: float
    speed: float
    dt: float
    steps: int
    landmarks: int
    ring_gap: float
    max_range: float
    speed_variance: float
    turn_rate_variance: float
    range_variance: float
    bearing_variance: float
    initial_pose_variance: tuple[float, float, float]
    fix_every: int | None
    fix_variance: float


@dataclass(frozen=True, kw_only=True)
class ScanParams(Config):
    """Parameters of [`LineExtractor`]. Lengths in metres, angles in radians.

    Attributes:
        min_range: Readings at or below this are invalid (0 is "no return" on most
            scanners).
        max_range: Readings at or beyond this are invalid (no return). Default: infinite.
        sigma_range: Standard deviation of the range noise (default 0.01 m).
        sigma_bearing: Standard deviation of the bearing noise (default 0: bearings are
            exact).
        breakpoint_lambda: Smallest incidence angle between a beam and a wall that still
            counts as one surface, lambda of the adaptive breakpoint detector (default 10
            degrees).
        split_epsilon: Iterative end-point fit splits where a point is farther than this
            from the chord (default 0.05 m).
        merge_confidence: Neighbouring lines merge when the Mahalanobis distance of their
            difference is below the chi-square (2 dof) quantile of this confidence (default
            0.99).
        min_points: Fewest points a wall may have (default 6; at least 2).
        min_length: Shortest wall kept (default 0.3 m).
        model_error: Inflate a line's covariance when its fit residuals show more scatter,
            or more correlation from point to point, than the range and bearing noise
            explain (default true; see `LineExtractor::model_error_factor`).
    """

    _native: ClassVar[str] = "scan_params"
    min_range: float = 0.0
    max_range: float = float("inf")
    sigma_range: float = 0.01
    sigma_bearing: float = 0.0
    breakpoint_lambda: float = 0.17453292519943295
    split_epsilon: float = 0.05
    merge_confidence: float = 0.99
    min_points: int = 6
    min_length: float = 0.3
    model_error: bool = True


class ScanParamsOverrides(TypedDict, total=False):
    """The fields of :class:`ScanParams`, for keyword arguments."""

    min_range: float
    max_range: float
    sigma_range: float
    sigma_bearing: float
    breakpoint_lambda: float
    split_epsilon: float
    merge_confidence: float
    min_points: int
    min_length: float
    model_error: bool


@dataclass(frozen=True, kw_only=True)
class SmootherConfig(Config):
    """How the smoother iterates.

    Attributes:
        max_iterations: At most this many Levenberg-Marquardt iterations (>= 1).
        tolerance: Converged when an accepted step lowers the cost by less than this
            fraction.
        point_huber: Huber's threshold (> 0) on a point sighting's whitened residual norm,
            in standard deviations: beyond it the sighting's cost grows linearly, so a few
            wrong sightings (which the filter's gate would refuse) cannot bend the path.
            `None`: plain least squares.
        point_correlation_time: Seconds (>= 0) over which the errors of one landmark's
            sightings stay correlated (a camera that misjudges a target keeps misjudging it
            while the view barely changes): each point sighting's information is divided by
            the number of that landmark's sightings within this time of it, itself included,
            so that a burst of them counts as about one. 0: every sighting independent.
    """

    _native: ClassVar[str] = "smoother"
    max_iterations: int = 100
    tolerance: float = 1e-09
    point_huber: float | None = None
    point_correlation_time: float = 0.0


class SmootherConfigOverrides(TypedDict, total=False):
    """The fields of :class:`SmootherConfig`, for keyword arguments."""

    max_iterations: int
    tolerance: float
    point_huber: float | None
    point_correlation_time: float


@dataclass(frozen=True, kw_only=True)
class CeilingConfig(Config):
    """How a ceiling is generated.

    Attributes:
        size: Extent along world x, metres (the ceiling spans `[0, size[0]] x [0,
            size[1]]`).
        resolution: Metres per texel.
        tile: Side of the square ceiling tiles, metres (0: no tile grid).
        texture_contrast: Amplitude of the repeated tile texture, grey levels (the clutter).
        n_patterns: Patterns placed.
        min_spacing: Least distance between two pattern centres, metres.
        seed: Seed of the layout and texture.
    """

    _native: ClassVar[str] = "ceiling"
    size: tuple[float, float] = (12.0, 8.0)
    resolution: float = 0.005
    tile: float = 0.6
    texture_contrast: float = 12.0
    n_patterns: int = 24
    min_spacing: float = 1.0
    seed: int = 0


class CeilingConfigOverrides(TypedDict, total=False):
    """The fields of :class:`CeilingConfig`, for keyword arguments."""

    size: tuple[float, float]
    resolution: float
    tile: float
    texture_contrast: float
    n_patterns: int
    min_spacing: float
    seed: int


@dataclass(frozen=True, kw_only=True)
class CameraMount(Config):
    """Where the camera sits on the robot: the camera frame in the robot frame, `X_R = R_m X_C
    + offset`, with `R_m = Rz(yaw) Ry(pitch) Rx(roll)` (radians). The ideal mount is all
    zeros.

    Attributes:
        roll: Rotation about the camera's x axis, radians.
        pitch: Rotation about y, radians.
        yaw: Rotation about z (the optical axis), radians.
        offset: The camera centre in the robot frame, metres.
    """

    roll: float = 0.0
    pitch: float = 0.0
    yaw: float = 0.0
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)


class CameraMountOverrides(TypedDict, total=False):
    """The fields of :class:`CameraMount`, for keyword arguments."""

    roll: float
    pitch: float
    yaw: float
    offset: tuple[float, float, float]


@dataclass(frozen=True, kw_only=True)
class CeilingCameraConfig(Config):
    """A pinhole camera looking up at a ceiling plane.

    # Examples ``` use rperc_core::Pose2; use navigation::ceiling::CeilingCamera;

    let camera = CeilingCamera::default(); // The ceiling point straight above the ideal
    camera is the principal point. let robot = Pose2::new(2.0, 1.0, 0.3); let uv =
    camera.project_ideal(&robot, [2.0, 1.0]); assert!((uv[0] - camera.cx).abs() < 1e-9 &&
    (uv[1] - camera.cy).abs() < 1e-9); ```

    Attributes:
        width: Image width, pixels.
        height: Image height, pixels.
        fx: Focal length along u, pixels.
        fy: Focal length along v, pixels.
        cx: Principal point, pixels (0-based, pixel centres at integers).
        cy: Principal point, pixels.
        ceiling_height: `d`: the height of the ceiling above the robot frame's origin,
            metres.
        mount: The camera-robot transform.
    """

    _native: ClassVar[str] = "ceiling_camera"
    width: int = 320
    height: int = 240
    fx: float = 160.0
    fy: float = 160.0
    cx: float = 159.5
    cy: float = 119.5
    ceiling_height: float = 2.5
    mount: CameraMount = field(default_factory=CameraMount)


class CeilingCameraConfigOverrides(TypedDict, total=False):
    """The fields of :class:`CeilingCameraConfig`, for keyword arguments."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    ceiling_height: float
    mount: CameraMount


@dataclass(frozen=True, kw_only=True)
class CeilingRenderConfig(Config):
    """The effects of one rendering.

    Attributes:
        noise: Standard deviation of the additive noise, grey levels.
        blur: Optical blur, pixels (standard deviation of a Gaussian).
        gain: Lighting gain `a` of `g -> a g + b`, uniform in this range per frame.
        offset: Lighting offset `b`, grey levels, uniform in this range per frame.
        occluder_probability: Chance that a frame holds an occluder (a dark disc, as a cable
            or a person's head passing between camera and ceiling).
        occluder_radius: The occluder's radius, as a fraction of the image height.
        outside_level: Grey level seen beyond the ceiling's edge (the walls).
        seed: Seed of every per-frame draw (frame `k` uses stream `k`).
    """

    _native: ClassVar[str] = "ceiling_render"
    noise: float = 2.0
    blur: float = 0.6
    gain: tuple[float, float] = (0.9, 1.1)
    offset: tuple[float, float] = (-10.0, 10.0)
    occluder_probability: float = 0.0
    occluder_radius: float = 0.15
    outside_level: float = 60.0
    seed: int = 0


class CeilingRenderConfigOverrides(TypedDict, total=False):
    """The fields of :class:`CeilingRenderConfig`, for keyword arguments."""

    noise: float
    blur: float
    gain: tuple[float, float]
    offset: tuple[float, float]
    occluder_probability: float
    occluder_radius: float
    outside_level: float
    seed: int


@dataclass(frozen=True, kw_only=True)
class OdometryNoise(Config):
    """How the odometry errs.

    Attributes:
        speed_scale_error: Relative error of the measured speed (the odometry reads `v (1 +
            e)`).
        turn_scale_error: Relative error of the measured turn rate.
        speed_sigma: White noise on each step's speed, m/s.
        turn_sigma: White noise on each step's turn rate, rad/s.
        seed: Seed of the noise.
    """

    _native: ClassVar[str] = "odometry_noise"
    speed_scale_error: float = 0.03
    turn_scale_error: float = -0.04
    speed_sigma: float = 0.02
    turn_sigma: float = 0.03
    seed: int = 0


class OdometryNoiseOverrides(TypedDict, total=False):
    """The fields of :class:`OdometryNoise`, for keyword arguments."""

    speed_scale_error: float
    turn_scale_error: float
    speed_sigma: float
    turn_sigma: float
    seed: int


@dataclass(frozen=True, kw_only=True)
class ProposalParams(Config):
    """How regions are proposed.

    Attributes:
        contrast: Least difference from the image's median grey that marks a pattern pixel.
        merge_gap: Blobs whose boxes come within this many pixels merge into one region: a
            light's frame and its bars, an arrow and its plate.
        min_area: Least blob area, pixels (smaller blobs carry too few contours to track).
        max_area_fraction: Largest region, as a fraction of the image area.
        margin: Pixels added around a blob's bounding box, so that its contours are inside.
        border: A region must keep this far from the image border (pixels), so that a
            pattern cut by the border is not learnt.
    """

    contrast: float = 45.0
    merge_gap: int = 2
    min_area: int = 30
    max_area_fraction: float = 0.25
    margin: int = 4
    border: int = 6


class ProposalParamsOverrides(TypedDict, total=False):
    """The fields of :class:`ProposalParams`, for keyword arguments."""

    contrast: float
    merge_gap: int
    min_area: int
    max_area_fraction: float
    margin: int
    border: int


@dataclass(frozen=True, kw_only=True)
class LocaliserParams(Config):
    """How the pose filter weighs the odometry and the trackers.

    Attributes:
        pixel_sigma: Standard deviation of a tracked model's image position, pixels.
        rotation_pixel_sigma: Standard deviation, in pixels at its rotation lever, of a
            tracked model's image rotation: the rotation's is this over the lever.
        min_rotation_lever: A model whose rotation lever is under this (pixels) tells no
            rotation: its tracker's turn lags a turning robot (a third of a 30 degree turn
            was seen missing on a model with a 6 px lever), an error that grows rather than
            averages out.
        odometry_sigma: Odometry error per step: `[relative to the distance, relative to the
            turn, floor in metres, floor in radians]`, each a standard deviation.
        odometry_scale_sigma: Standard deviation of the odometry's scale errors `[distance,
            turn]` (relative), estimated as two states of the filter: an uncalibrated wheel
            odometry errs the same way at every step, which the per-step errors of
            `odometry_sigma` cannot describe (they grow with the square root of the turn, a
            scale error with the turn itself). 0 leaves a scale out.
        gate_probability: A model's innovation is refused above this chi-square probability
            (3 dof).
        max_refused_frames: After this many frames in a row in which every tracked model was
            refused, the filter restarts from the models (the prediction, not they, was
            wrong).
        settle_frames: A restarted tracker's state is used after this many updates: it
            starts at the filter's own prediction, and using it at once would confirm the
            prediction.
        guess_sigma: Standard deviation of a localiser's starting guess `[x m, y m, theta
            rad]`.
        search_sigmas: When the filter's pose is too uncertain for a tracker started at a
            model's predicted image pose (this many standard deviations of that prediction
            reach beyond the tracker's random walk), the robot pose is searched over this
            many standard deviations of the filter's instead (see [`super::search_pose`]); 0
            never searches.
        rigid_map: Localising against a stored mosaic, its models are consider states (see
            [`PoseFilter::with_map`]): the sightings correct the robot, never the mosaic.
            False corrects both, as while mapping.
    """

    pixel_sigma: float = 0.3
    rotation_pixel_sigma: float = 0.8
    min_rotation_lever: float = 12.0
    odometry_sigma: tuple[float, float, float, float] = (0.05, 0.05, 0.003, 0.004)
    odometry_scale_sigma: tuple[float, float] = (0.0, 0.0)
    gate_probability: float = 0.999
    max_refused_frames: int = 3
    settle_frames: int = 2
    guess_sigma: tuple[float, float, float] = (0.06, 0.06, 0.06)
    search_sigmas: float = 3.0
    rigid_map: bool = True


class LocaliserParamsOverrides(TypedDict, total=False):
    """The fields of :class:`LocaliserParams`, for keyword arguments."""

    pixel_sigma: float
    rotation_pixel_sigma: float
    min_rotation_lever: float
    odometry_sigma: tuple[float, float, float, float]
    odometry_scale_sigma: tuple[float, float]
    gate_probability: float
    max_refused_frames: int
    settle_frames: int
    guess_sigma: tuple[float, float, float]
    search_sigmas: float
    rigid_map: bool


@dataclass(frozen=True, kw_only=True)
class MosaicParams(Config):
    """How the mosaic is built and the robot localised.

    Attributes:
        tracker: Each model's tracker.
        proposals: Where new models are proposed.
        max_tracked: At most this many models are tracked at once.
        min_tracked: While mapping, new models are generated when fewer than this are
            tracked.
        min_score: A tracker whose score falls below this is stopped (its model is lost).
        view_margin: A model is stopped when its box comes this close to the image border
            (pixels), and restarted when its predicted box is 3 pixels further inside.
        metric: Poses in metres (`Z / f` from the camera) or, when false, in ideal-image
            pixels ("up to the scale factor Z/f").
        localiser: The pose filter that fuses the odometry and the tracked models (eq. 2).
        min_visible: A model is tracked while at least this fraction of its contour points
            lies in the view (`view_margin` inside it), and restarted when the prediction
            puts this fraction there with the hysteresis; 1 asks for its whole box.
        odometry_prediction: Each tracker's state is moved by the image motion the odometry
            predicts before it weighs the next frame (a control input of its dynamics);
            false leaves the whole motion to its random walk, as in the seed.
    """

    tracker: PatternConfig = field(
        default_factory=lambda: PatternConfig(
            n_particles=100,
            sigma=(4.0, 4.0, 0.026179938779914945, 0.02),
            refine_steps=4,
            refine_first_step=0.25,
            refined_particle=False,
            refine_fine_rounds=2,
            newton_steps=0,
            coarse_particles=0,
        )
    )
    proposals: ProposalParams = field(default_factory=ProposalParams)
    max_tracked: int = 4
    min_tracked: int = 3
    min_score: float = 0.6
    view_margin: float = 2.0
    metric: bool = True
    localiser: LocaliserParams = field(default_factory=LocaliserParams)
    min_visible: float = 0.75
    odometry_prediction: bool = True


class MosaicParamsOverrides(TypedDict, total=False):
    """The fields of :class:`MosaicParams`, for keyword arguments."""

    tracker: PatternConfig
    proposals: ProposalParams
    max_tracked: int
    min_tracked: int
    min_score: float
    view_margin: float
    metric: bool
    localiser: LocaliserParams
    min_visible: float
    odometry_prediction: bool


@dataclass(frozen=True, kw_only=True)
class KeyImageParams(Config):
    """When a new key image is taken.

    Attributes:
        max_turn: Condition (ii): the largest turn of a shared model between successive key
            images, radians.
        max_shift: The largest image displacement of a shared model between successive key
            images, pixels: short elementary trajectories keep the replay close to the
            learnt path (the seed's "approximatively fits").
        max_travel: The largest travel of the robot between successive key images, ideal-
            image pixels (its pose in the mosaic over the mosaic's units per pixel): a model
            near the turn's centre barely shifts in the image while the robot drives on, and
            one such model alone is a poor guide over a long stretch.
    """

    max_turn: float = 0.3490658503988659
    max_shift: float = 60.0
    max_travel: float = 60.0


class KeyImageParamsOverrides(TypedDict, total=False):
    """The fields of :class:`KeyImageParams`, for keyword arguments."""

    max_turn: float
    max_shift: float
    max_travel: float


@dataclass(frozen=True, kw_only=True)
class LearnConfig(Config):
    """How a learning run goes.

    Attributes:
        mosaic: Mosaic building.
        keys: Key image selection.
        odometry: How the odometry errs (the robot drives the commands exactly; its odometry
            reads them with these errors).
        covariance_scale: The stored mosaic's covariance (each model's and the joint one) is
            the mapping filter's times this: the filter counts a tracker's successive states
            as independent, but a tracker's error lasts while it tracks (its frame-to-frame
            correlation is 0.65, still 0.38 ten frames apart), and the mosaic it builds is
            that much less certain than it claims.
    """

    _native: ClassVar[str] = "memory_learn"
    mosaic: MosaicParams = field(default_factory=MosaicParams)
    keys: KeyImageParams = field(default_factory=KeyImageParams)
    odometry: OdometryNoise = field(default_factory=OdometryNoise)
    covariance_scale: float = 1.0


class LearnConfigOverrides(TypedDict, total=False):
    """The fields of :class:`LearnConfig`, for keyword arguments."""

    mosaic: MosaicParams
    keys: KeyImageParams
    odometry: OdometryNoise
    covariance_scale: float


@dataclass(frozen=True, kw_only=True)
class ServoParams(Config):
    """Gains and limits of the servoing law.

    Attributes:
        gain_distance: Forward gain, 1/s (pixels of error to pixels per second).
        gain_bearing: Turn gain on the bearing to the goal, 1/s.
        gain_heading: Turn gain on the heading error near the goal, 1/s.
        max_speed: Largest forward speed, ideal-image pixels per second.
        max_turn_rate: Largest turn rate, rad/s.
        switch_error: An intermediate key image is passed when the error falls under this
            (pixels).
        final_error: The last key image (B) is reached when the error falls under this
            (pixels).
        align_radius: Within this distance of the goal (pixels) the heading error is
            corrected.
    """

    gain_distance: float = 0.8
    gain_bearing: float = 1.5
    gain_heading: float = 0.8
    max_speed: float = 25.0
    max_turn_rate: float = 0.25
    switch_error: float = 12.0
    final_error: float = 1.5
    align_radius: float = 0.0


class ServoParamsOverrides(TypedDict, total=False):
    """The fields of :class:`ServoParams`, for keyword arguments."""

    gain_distance: float
    gain_bearing: float
    gain_heading: float
    max_speed: float
    max_turn_rate: float
    switch_error: float
    final_error: float
    align_radius: float


@dataclass(frozen=True, kw_only=True)
class ReplayConfig(Config):
    """How a replay runs.

    Attributes:
        mosaic: The localiser (tracker parameters; mapping is off).
        servo: The servoing law.
        dt: Control period, seconds (one frame per period).
        max_frames: The replay gives up after this many frames.
        max_blind_frames: The robot gives up after this many frames in a row without a model
            shared with its current key image.
        metres_per_pixel: Metres per ideal-image pixel the controller assumes to turn its
            pixel commands into wheel speeds (a gain: any rough value of `Z / f` will do).
        actuation: How the wheels err: the true motion is the command with these scale
            errors and noise; the odometry reads the command.
    """

    _native: ClassVar[str] = "memory_replay"
    mosaic: MosaicParams = field(default_factory=MosaicParams)
    servo: ServoParams = field(default_factory=ServoParams)
    dt: float = 0.1
    max_frames: int = 1500
    max_blind_frames: int = 20
    metres_per_pixel: float = 0.015
    actuation: OdometryNoise = field(default_factory=OdometryNoise)


class ReplayConfigOverrides(TypedDict, total=False):
    """The fields of :class:`ReplayConfig`, for keyword arguments."""

    mosaic: MosaicParams
    servo: ServoParams
    dt: float
    max_frames: int
    max_blind_frames: int
    metres_per_pixel: float
    actuation: OdometryNoise
