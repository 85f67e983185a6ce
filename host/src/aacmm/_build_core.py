"""cffi build script: binds the firmware's kinematics core into ``aacmm._core``.

Run by setuptools (``cffi_modules`` in host/setup.py) when the package is
built or installed; it compiles the firmware's own C sources (in a checkout
the repository's firmware/, in an sdist the copy setup.py bundled under
csrc/), so the host analysis runs exactly the code the arm runs.
"""

from __future__ import annotations

from pathlib import Path

from cffi import FFI

_HERE = Path(__file__).resolve().parent
HOST = _HERE.parents[1]  # host/src/aacmm -> host
# The firmware's C sources: bundled under host/csrc/ in an sdist (setup.py's
# sdist command copies them there), else the repository's firmware/ next to host/.
_BUNDLED = HOST / "csrc" / "firmware"
_CHECKOUT = HOST.parent / "firmware"
FIRMWARE = _BUNDLED if _BUNDLED.is_dir() else _CHECKOUT
FW_INC = FIRMWARE / "include"
FW_SRC = FIRMWARE / "src"
SOURCES = [
    FW_SRC / "status.c",
    FW_SRC / "encoder.c",
    FW_SRC / "kinematics_f64.c",
    FW_SRC / "kinematics_f32.c",
    FW_SRC / "analysis.c",
    FW_SRC / "simd" / "simd_dispatch.c",
    FW_SRC / "simd" / "simd_f64.c",
    FW_SRC / "simd" / "simd_f32.c",
]


def c_sources() -> list[tuple[Path, str]]:
    """Every file the extension is compiled from, as (path, path under csrc/).

    The sources above and every header they may include: the public headers
    and the core's own (firmware/src and firmware/src/simd, not the device,
    simulator or protocol directories).
    """
    root = FIRMWARE.parent
    files = sorted(FW_INC.glob("aacmm/*.h"))
    for d in (FW_SRC, FW_SRC / "simd"):
        files += sorted(p for p in d.iterdir() if p.suffix in (".c", ".h"))
    return [(p, p.relative_to(root).as_posix()) for p in files]


if not (FW_SRC / "kinematics_impl.h").is_file():
    raise RuntimeError(
        f"aacmm: the C sources of the kinematics core are missing (looked in {_BUNDLED} and "
        f"{_CHECKOUT}): build the package from the repository's host/ directory, or from an "
        "sdist made there (python -m build --sdist host/ or pip wheel host/)"
    )

CDEF = """
typedef enum {
    AACMM_OK, AACMM_ERR_NULL, AACMM_ERR_RANGE, AACMM_ERR_NOT_FINITE, ...
} aacmm_status_t;
const char *aacmm_status_str(aacmm_status_t status);

typedef struct {
    double theta_offset_rad[6];
    double alpha_rad[6];
    double d_mm[6];
    double a_mm[6];
    double l_mm;
} aacmm_params_f64_t;

typedef struct {
    aacmm_params_f64_t params;
    double sin_alpha[6];
    double cos_alpha[6];
} aacmm_model_f64_t;

typedef struct {
    float theta_offset_rad[6];
    float alpha_rad[6];
    float d_mm[6];
    float a_mm[6];
    float l_mm;
} aacmm_params_f32_t;

typedef struct {
    aacmm_params_f32_t params;
    float sin_alpha[6];
    float cos_alpha[6];
} aacmm_model_f32_t;

typedef struct {
    uint64_t counts_per_rev[6];
    uint32_t zero_offset_counts[6];
    int8_t direction[6];
} aacmm_encoder_config_t;

aacmm_status_t aacmm_params_default_f64(aacmm_params_f64_t *params);
aacmm_status_t aacmm_params_validate_f64(const aacmm_params_f64_t *params);
aacmm_status_t aacmm_model_init_f64(aacmm_model_f64_t *model, const aacmm_params_f64_t *params);
aacmm_status_t aacmm_encoder_validate(const aacmm_encoder_config_t *config);
aacmm_status_t aacmm_encoder_to_angles_f64(const aacmm_encoder_config_t *config,
                                           const uint32_t reading_counts[6], double theta_rad[6]);
aacmm_status_t aacmm_point_f64(const aacmm_model_f64_t *model, const double theta_rad[6],
                               double p_mm[3]);
aacmm_status_t aacmm_point_jacobian_f64(const aacmm_model_f64_t *model,
                                        const double theta_rad[6], double p_mm[3],
                                        double jac[75]);
aacmm_status_t aacmm_batch_angles_f64(const aacmm_model_f64_t *model, size_t n,
                                      const double *theta_rad, double *p_mm, double *jac,
                                      size_t *done);
aacmm_status_t aacmm_batch_counts_f64(const aacmm_model_f64_t *model,
                                      const aacmm_encoder_config_t *encoders, size_t n,
                                      const uint32_t *reading_counts, double *p_mm, double *jac,
                                      size_t *done);
aacmm_status_t aacmm_abs_jacobian_sums_f64(const aacmm_model_f64_t *model, size_t n,
                                           const double *theta_rad, double abs_sum[75],
                                           double sq_sum[75], size_t *done);
aacmm_status_t aacmm_perturbed_points_f64(const aacmm_params_f64_t *nominal, size_t n_trials,
                                          const double *delta, size_t n_poses,
                                          const double *theta_rad, double *p_mm, size_t *done);
aacmm_status_t aacmm_model_init_f32(aacmm_model_f32_t *model, const aacmm_params_f32_t *params);

typedef enum {
    AACMM_KERNEL_SCALAR, AACMM_KERNEL_VEC128, AACMM_KERNEL_AVX2, AACMM_KERNEL_AVX512
} aacmm_kernel_t;
int aacmm_kernel_available(aacmm_kernel_t kernel);
aacmm_kernel_t aacmm_kernel_best(void);
int aacmm_kernel_fused(aacmm_kernel_t kernel);
const char *aacmm_kernel_name(aacmm_kernel_t kernel);
unsigned aacmm_kernel_lanes(aacmm_kernel_t kernel, int single);
aacmm_status_t aacmm_simd_batch_angles_f64(aacmm_kernel_t kernel, const aacmm_model_f64_t *model,
                                           size_t n, const double *theta_rad, double *p_mm,
                                           double *jac, size_t *done);
aacmm_status_t aacmm_simd_batch_angles_f32(aacmm_kernel_t kernel, const aacmm_model_f32_t *model,
                                           size_t n, const float *theta_rad, float *p_mm,
                                           float *jac, size_t *done);
aacmm_status_t aacmm_simd_batch_angles_tiled_f64(aacmm_kernel_t kernel,
                                                 const aacmm_model_f64_t *model, size_t n,
                                                 const double *theta_rad, double *p_mm,
                                                 double *jac_tiled, size_t *done);
aacmm_status_t aacmm_simd_batch_angles_tiled_f32(aacmm_kernel_t kernel,
                                                 const aacmm_model_f32_t *model, size_t n,
                                                 const float *theta_rad, float *p_mm,
                                                 float *jac_tiled, size_t *done);
aacmm_status_t aacmm_simd_abs_jacobian_sums_f64(aacmm_kernel_t kernel,
                                                const aacmm_model_f64_t *model, size_t n,
                                                const double *theta_rad, double abs_sum[75],
                                                double sq_sum[75], size_t *done);
aacmm_status_t aacmm_simd_abs_jacobian_sums_scaled_f64(
    aacmm_kernel_t kernel, const aacmm_model_f64_t *model, size_t n, const double *unit,
    const double scale[6], const double offset[6], double abs_sum[75], double sq_sum[75],
    size_t *done);
aacmm_status_t aacmm_simd_perturbed_points_f64(aacmm_kernel_t kernel,
                                               const aacmm_params_f64_t *nominal,
                                               size_t n_trials, const double *delta,
                                               size_t n_poses, const double *theta_rad,
                                               double *p_mm, size_t *done);
aacmm_status_t aacmm_counts_to_angles_f64(const aacmm_encoder_config_t *encoders, size_t n,
                                          const uint32_t *reading_counts, double *theta_rad,
                                          size_t *done);
"""

ffibuilder = FFI()
ffibuilder.cdef(CDEF)


# One translation unit (a "unity build") that includes the firmware sources:
# no object files land outside the build directory, and the compiler may
# inline the core's per-pose function into the analysis loops.
#
# No -march: the extension runs on any CPU of its architecture (x86-64
# baseline, arm64). The wide batch kernels (AVX2, AVX-512) are compiled under
# target attributes inside firmware/src/simd and chosen at run time
# (aacmm/simd.h). No FMA contraction: the kernels then give the scalar
# kernel's results bit for bit.
UNITY = "".join(f'#include "{p.relative_to(FW_SRC).as_posix()}"\n' for p in SOURCES)
ffibuilder.set_source(
    "aacmm._core",
    UNITY,
    include_dirs=[str(FW_INC), str(FW_SRC)],
    depends=[str(p) for p in SOURCES],
    extra_compile_args=["-std=c99", "-O3", "-fno-math-errno", "-ffp-contract=off"],
    libraries=["m"],
)

if __name__ == "__main__":
    ffibuilder.compile(verbose=True)
