// cmlt.hpp — a small header-only C++17 wrapper over cmlt.h: RAII handles
// (move-only, released in their destructors), enum classes for the C
// constants, and callbacks taken as any callable. It adds no behaviour:
// every member is one C call, returns that call's `Status`
// ([[nodiscard]]) and throws nothing, so engines built without exceptions
// can use it. `cmlt_last_error()` has the message of a failed call.
#ifndef CMLT_HPP
#define CMLT_HPP

#include <cstddef>
#include <cstdint>
#include <type_traits>
#include <utility>

#include "cmlt.h"

namespace cmlt {

/// The result of every call (`cmlt_status`).
enum class Status : std::uint32_t {
    Ok = CMLT_OK,
    NullPointer = CMLT_ERROR_NULL_POINTER,
    InvalidArgument = CMLT_ERROR_INVALID_ARGUMENT,
    InvalidOperation = CMLT_ERROR_INVALID_OPERATION,
    Busy = CMLT_ERROR_BUSY,
    Io = CMLT_ERROR_IO,
    Unsupported = CMLT_ERROR_UNSUPPORTED,
    Internal = CMLT_ERROR_INTERNAL,
    OutOfMemory = CMLT_ERROR_OUT_OF_MEMORY,
};

/// The estimators (`CMLT_ESTIMATOR_*`).
enum class Estimator : std::uint32_t {
    Pt = CMLT_ESTIMATOR_PT,
    Bdpt = CMLT_ESTIMATOR_BDPT,
    Mlt = CMLT_ESTIMATOR_MLT,
    Cmlt = CMLT_ESTIMATOR_CMLT,
};

/// Pixel formats of `Renderer::resolve` (`CMLT_FORMAT_*`).
enum class Format : std::uint32_t {
    Rgb32f = CMLT_FORMAT_RGB32F,
    Rgba8Srgb = CMLT_FORMAT_RGBA8_SRGB,
};

/// How every estimator carries its accumulation into the next frame
/// (`CMLT_ACCUMULATION_*`, `Renderer::set_accumulation`).
enum class Accumulation : std::uint32_t {
    Reset = CMLT_ACCUMULATION_RESET,
    Keep = CMLT_ACCUMULATION_KEEP,
    Decay = CMLT_ACCUMULATION_DECAY,
};

/// `Renderer::set_pixel_block`: the block size chosen from the workers'
/// measured samples (`CMLT_PIXEL_BLOCK_FIT`).
constexpr std::uint32_t pixel_block_fit = CMLT_PIXEL_BLOCK_FIT;

/// A status's readable name.
inline const char *name(Status s) { return cmlt_status_name(static_cast<std::uint32_t>(s)); }

/// The message of the last failed call on this thread.
inline const char *last_error() { return cmlt_last_error(); }

namespace detail {
inline Status status(cmlt_status s) { return static_cast<Status>(s); }

/// A callable's address as the C callbacks' `user` pointer.
template <class F> void *user(F &f) { return const_cast<void *>(static_cast<const void *>(&f)); }

/// Calls a host callable through the C callback `cmlt_keep_going_fn`.
template <class F> std::uint32_t keep_going(void *user, std::uint64_t done) {
    return (*static_cast<F *>(user))(done) ? 1u : 0u;
}
} // namespace detail

/// The defaults of a renderer configuration for `estimator`
/// (`cmlt_renderer_config_default`); set width and height.
inline cmlt_renderer_config config_default(Estimator estimator) {
    cmlt_renderer_config c{};
    // Cannot fail for an `Estimator` value.
    (void)cmlt_renderer_config_default(static_cast<std::uint32_t>(estimator), &c);
    return c;
}

/// A scene (`cmlt_scene`): built from the host's arrays, then committed.
class Scene {
  public:
    Scene() = default;
    Scene(const Scene &) = delete;
    Scene &operator=(const Scene &) = delete;
    Scene(Scene &&o) noexcept : p_(std::exchange(o.p_, nullptr)) {}
    Scene &operator=(Scene &&o) noexcept {
        std::swap(p_, o.p_);
        return *this;
    }
    ~Scene() { cmlt_scene_release(p_); }

    /// A new empty scene into `out`.
    [[nodiscard]] static Status create(Scene &out) {
        cmlt_scene *p = nullptr;
        Status s = detail::status(cmlt_scene_new(&p));
        if (s == Status::Ok) out = Scene(p);
        return s;
    }
    [[nodiscard]] Status add_material(const cmlt_material &m, std::uint32_t &id) {
        return detail::status(cmlt_scene_add_material(p_, &m, &id));
    }
    [[nodiscard]] Status add_mesh(const cmlt_mesh &m, std::uint32_t *first_triangle = nullptr) {
        return detail::status(cmlt_scene_add_mesh(p_, &m, first_triangle));
    }
    /// An image texture from host memory (`cmlt_scene_add_texture`); its id
    /// into `id`.
    [[nodiscard]] Status add_texture(std::uint32_t width, std::uint32_t height, std::uint32_t channels,
                                     const std::uint8_t *texels, std::size_t stride, bool srgb,
                                     std::uint32_t &id) {
        return detail::status(
            cmlt_scene_add_texture(p_, width, height, channels, texels, stride, srgb ? 1u : 0u, &id));
    }
    /// A voxel-grid texture read at world positions
    /// (`cmlt_scene_add_grid_texture`); its id, shared with image textures,
    /// into `id`.
    [[nodiscard]] Status add_grid_texture(const cmlt_grid &g, std::uint32_t &id) {
        return detail::status(cmlt_scene_add_grid_texture(p_, &g, &id));
    }
    /// A homogeneous medium; its id into `id`.
    [[nodiscard]] Status add_medium(const cmlt_medium &m, std::uint32_t &id) {
        return detail::status(cmlt_scene_add_medium(p_, &m, &id));
    }
    /// The media inside and outside mesh `mesh` (`CMLT_MEDIUM_NONE`: vacuum).
    [[nodiscard]] Status set_mesh_media(std::uint32_t mesh, std::uint32_t interior, std::uint32_t exterior) {
        return detail::status(cmlt_scene_set_mesh_media(p_, mesh, interior, exterior));
    }
    /// The medium the cameras sit in (`CMLT_MEDIUM_NONE`: vacuum).
    [[nodiscard]] Status set_camera_medium(std::uint32_t medium) {
        return detail::status(cmlt_scene_set_camera_medium(p_, medium));
    }
    [[nodiscard]] Status commit() { return detail::status(cmlt_scene_commit(p_)); }
    /// Lights of the committed scene that emit (0: every frame is black).
    [[nodiscard]] Status light_count(std::uint32_t &count) const {
        return detail::status(cmlt_scene_light_count(p_, &count));
    }
    /// Moves mesh `mesh` (packed or strided positions; normals optional).
    [[nodiscard]] Status update_mesh(std::uint32_t mesh, const float *positions, std::size_t vertex_count,
                                     std::size_t position_stride = 0, const float *normals = nullptr,
                                     std::size_t normal_stride = 0) {
        return detail::status(
            cmlt_scene_update_mesh(p_, mesh, positions, vertex_count, position_stride, normals, normal_stride));
    }
    cmlt_scene *get() const { return p_; }

  private:
    explicit Scene(cmlt_scene *p) : p_(p) {}
    cmlt_scene *p_ = nullptr;
};

/// A renderer (`cmlt_renderer`) over a committed scene.
class Renderer {
  public:
    Renderer() = default;
    Renderer(const Renderer &) = delete;
    Renderer &operator=(const Renderer &) = delete;
    Renderer(Renderer &&o) noexcept : p_(std::exchange(o.p_, nullptr)) {}
    Renderer &operator=(Renderer &&o) noexcept {
        std::swap(p_, o.p_);
        return *this;
    }
    ~Renderer() { cmlt_renderer_release(p_); }

    /// A renderer of `scene` through `camera` into `out`.
    [[nodiscard]] static Status create(const Scene &scene, const cmlt_renderer_config &config,
                                       const cmlt_camera &camera, Renderer &out) {
        cmlt_renderer *p = nullptr;
        Status s = detail::status(cmlt_renderer_new(scene.get(), &config, &camera, &p));
        if (s == Status::Ok) out = Renderer(p);
        return s;
    }
    [[nodiscard]] Status set_camera(const cmlt_camera &camera) {
        return detail::status(cmlt_renderer_set_camera(p_, &camera));
    }
    /// Keep, decay (by `decay` per frame) or reset the accumulation at
    /// the next frames (every estimator).
    [[nodiscard]] Status set_accumulation(Accumulation mode, float decay = 0.0f) {
        return detail::status(cmlt_renderer_set_accumulation(p_, static_cast<std::uint32_t>(mode), decay));
    }
    /// How many pixels each PT or BDPT sample fills from the next pass
    /// on: 1 (full resolution, the default) ..= 64, or `pixel_block_fit`
    /// (dynamic resolution from the measured samples); MLT and CMLT at
    /// any size but 1 mix such BDPT samples with their chains' splats
    /// (the block fill: full frames far below one mutation per pixel).
    [[nodiscard]] Status set_pixel_block(std::uint32_t size) {
        return detail::status(cmlt_renderer_set_pixel_block(p_, size));
    }
    [[nodiscard]] Status prepare() { return detail::status(cmlt_renderer_prepare(p_)); }
    [[nodiscard]] Status prepare_begin(bool &pending) {
        std::uint32_t p = 0;
        Status s = detail::status(cmlt_renderer_prepare_begin(p_, &p));
        pending = p != 0;
        return s;
    }
    /// Worker `worker`'s share of the set-up, asking `keep_going(done)`
    /// between pieces; `finished` says whether the share is complete.
    template <class F>
    [[nodiscard]] Status prepare_worker_while(std::uint32_t worker, F &&keep_going, bool &finished) {
        using Fn = std::remove_reference_t<F>;
        std::uint32_t f = 0;
        Status s = detail::status(cmlt_renderer_prepare_worker_while(
            p_, worker, &detail::keep_going<Fn>, detail::user(keep_going), &f));
        finished = f != 0;
        return s;
    }
    [[nodiscard]] Status prepare_worker(std::uint32_t worker) {
        return detail::status(cmlt_renderer_prepare_worker(p_, worker));
    }
    [[nodiscard]] Status prepare_finish() { return detail::status(cmlt_renderer_prepare_finish(p_)); }
    [[nodiscard]] Status render(std::uint32_t worker, std::uint64_t budget, std::uint64_t *done = nullptr) {
        return detail::status(cmlt_renderer_render(p_, worker, budget, done));
    }
    /// Renders worker `worker` while `keep_going(done)` says yes (any
    /// callable taking the units done so far), up to `budget` units.
    template <class F>
    [[nodiscard]] Status render_while(std::uint32_t worker, std::uint64_t budget, F &&keep_going,
                                      std::uint64_t *done = nullptr) {
        using Fn = std::remove_reference_t<F>;
        return detail::status(cmlt_renderer_render_while(p_, worker, budget, &detail::keep_going<Fn>,
                                                         detail::user(keep_going), done));
    }
    [[nodiscard]] Status resolve(Format format, void *pixels, std::size_t row_stride, std::size_t size) const {
        return detail::status(cmlt_renderer_resolve(p_, static_cast<std::uint32_t>(format),
                                                    static_cast<std::uint8_t *>(pixels), row_stride, size));
    }
    [[nodiscard]] Status stats(cmlt_stats &out) const { return detail::status(cmlt_renderer_get_stats(p_, &out)); }
    cmlt_renderer *get() const { return p_; }

  private:
    explicit Renderer(cmlt_renderer *p) : p_(p) {}
    cmlt_renderer *p_ = nullptr;
};

} // namespace cmlt

#endif // CMLT_HPP
