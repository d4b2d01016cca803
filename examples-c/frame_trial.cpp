// frame_trial.cpp — a game engine's frame loop over cmlt, in C++17 through
// include/cmlt.hpp, and the measurement behind `cmlt-bench frames`.
//
// The host owns a ~5k-triangle room in its own arrays (six subdivided
// walls, a ceiling light, two spheres and a third one that it moves every
// frame with cmlt_scene_update_mesh), dollies the camera forwards, renders
// every frame on two host threads (one per worker) within a time budget
// through cmlt_renderer_render_while, and resolves the image. Every cmlt
// allocation goes through a counting allocator (cmlt_set_allocator).
//
// Usage: frame_trial [ESTIMATOR [WIDTH HEIGHT [BUDGET_MS [FRAMES [UNITS]]]]]
//   ESTIMATOR: pt | bdpt | mlt | cmlt (default pt), 320 180 30 120; each
//   takes a suffix +keep or +decay (factor 0.8) for its accumulation
//   across frames (reset otherwise). Every estimator renders with the
//   block size fitted to the frame's samples (cmlt_renderer_set_pixel_block
//   with CMLT_PIXEL_BLOCK_FIT: dynamic resolution, a full image every
//   frame): PT and BDPT their passes, MLT and CMLT their block fill (BDPT
//   samples mixed with the chains' splats); a further suffix +full keeps
//   them at full resolution (PT and BDPT frames below one pass then show
//   only the pixels they reached, MLT and CMLT their chains alone).
//   UNITS > 0 replaces the clock by a count: each worker renders UNITS
//   units a frame (`render_while`'s count; the set-up still gets its 5 %
//   of BUDGET_MS), for measurements at a fixed work per frame, whatever
//   the machine's load.
// MLT and CMLT keep their chains across frames (one normalisation pass
// per bootstrap, b tracked from the large steps of the last 32 frames);
// after the first frame
// their set-up gets 5 % of the budget (prepare_worker_while), the rest
// renders. Prints one line per frame, then one `trial` line:
//   trial <estimator> <w>x<h> budget_ms <b> frames <n> p50_ms <..> p95_ms <..>
//   setup_ms <..> setup_p50_ms <..> black <..> flicker <..> allocs_per_frame <..>
//   cpu_p50_ms <..> cpu_p95_ms <..> over <..> over_lost_ms <..> setup_cpu_ms <..>
// setup_ms, setup_p50_ms: the mean and the median time of the set-up
// after the first frame (from its start until both workers may render);
// black: the mean fraction of exactly black pixels; flicker: the rms of
// the relative frame-to-frame change of the mean luminance.
// cpu_*_ms: a frame's work as thread CPU time (CLOCK_THREAD_CPUTIME_ID):
// the busier worker's thread over its set-up and render, plus the
// resolve's; over: the frames after the first longer than the budget +
// 10 %, and over_lost_ms their mean wall time not spent on the CPU (frame
// time minus that work) — a frame that is late because the scheduler held
// a thread back loses its time there, one that did too much work does
// not; setup_cpu_ms: the mean of the busier worker's thread CPU time over
// its set-up and the join after the first frame (against setup_ms, its
// wall time).
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "cmlt.hpp"

namespace {

using Clock = std::chrono::steady_clock;

void check(cmlt::Status s, const char *what) {
    if (s != cmlt::Status::Ok) {
        std::fprintf(stderr, "%s failed: %s (%s)\n", what, cmlt::name(s), cmlt::last_error());
        std::exit(1);
    }
}

// ---- The host's allocator: counts every block cmlt asks for. ----

std::atomic<unsigned long> g_allocations{0};

void *count_alloc(void *, std::size_t size, std::size_t align) {
    g_allocations.fetch_add(1, std::memory_order_relaxed);
    return std::aligned_alloc(std::max(align, sizeof(void *)),
                              (size + std::max(align, sizeof(void *)) - 1) / std::max(align, sizeof(void *)) *
                                  std::max(align, sizeof(void *)));
}

void count_free(void *, void *ptr, std::size_t, std::size_t) { std::free(ptr); }

// ---- The host's geometry: packed xyz positions per mesh. ----

struct Mesh {
    std::vector<float> positions; // x, y, z per vertex
    std::vector<std::uint32_t> indices;
};

// A w × h grid of quads spanning corner + s·u + t·v, s, t ∈ [0, 1]
// (front side: u × v).
Mesh grid(const std::array<float, 3> &corner, const std::array<float, 3> &u, const std::array<float, 3> &v,
          int n) {
    Mesh m;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            float s = float(i) / float(n), t = float(j) / float(n);
            for (int k = 0; k < 3; ++k) m.positions.push_back(corner[k] + s * u[k] + t * v[k]);
        }
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            std::uint32_t a = std::uint32_t(j * (n + 1) + i), b = a + 1, c = a + std::uint32_t(n + 1), d = c + 1;
            m.indices.insert(m.indices.end(), {a, b, d, a, d, c});
        }
    return m;
}

Mesh sphere(float cx, float cy, float cz, float r, int rings, int segments) {
    Mesh m;
    for (int i = 0; i <= rings; ++i) {
        float th = 3.14159265f * float(i) / float(rings);
        for (int j = 0; j < segments; ++j) {
            float ph = 6.2831853f * float(j) / float(segments);
            m.positions.insert(m.positions.end(), {cx + r * std::sin(th) * std::cos(ph), cy + r * std::cos(th),
                                                   cz + r * std::sin(th) * std::sin(ph)});
        }
    }
    for (int i = 0; i < rings; ++i)
        for (int j = 0; j < segments; ++j) {
            auto a = std::uint32_t(i * segments + j), b = std::uint32_t(i * segments + (j + 1) % segments);
            auto c = a + std::uint32_t(segments), d = b + std::uint32_t(segments);
            m.indices.insert(m.indices.end(), {a, b, d, a, d, c});
        }
    return m;
}

cmlt_material diffuse(float r, float g, float b) {
    cmlt_material m{};
    m.type_ = CMLT_MATERIAL_DIFFUSE;
    m.color[0] = r;
    m.color[1] = g;
    m.color[2] = b;
    m.ior = 1.0f;
    m.bump_scale = 1.0f;
    for (int k = 0; k < 3; ++k) m.specular_color[k] = m.transmission_color[k] = 1.0f;
    m.distribution = CMLT_DISTRIBUTION_GGX;
    return m;
}

void add(cmlt::Scene &scene, const Mesh &m, std::uint32_t material, float emission = 0.0f) {
    cmlt_mesh d{};
    d.positions = m.positions.data();
    d.vertex_count = m.positions.size() / 3;
    d.indices = m.indices.data();
    d.triangle_count = m.indices.size() / 3;
    d.material = material;
    d.emission[0] = d.emission[1] = d.emission[2] = emission;
    check(scene.add_mesh(d), "add_mesh");
}

// Where the workers meet between their set-up and their render: the last
// to arrive runs `done` (the join of their shares) before any goes on. (A
// one-use barrier per frame: std::barrier is C++20.)
class Meeting {
  public:
    explicit Meeting(int parties) : waiting_(parties) {}
    template <class F> void arrive(F &&done) {
        std::unique_lock<std::mutex> lock(m_);
        if (--waiting_ == 0) {
            done();
            open_ = true;
            cv_.notify_all();
        } else {
            cv_.wait(lock, [this] { return open_; });
        }
    }

  private:
    std::mutex m_;
    std::condition_variable cv_;
    int waiting_;
    bool open_ = false;
};

// The calling thread's CPU time, milliseconds (POSIX).
double thread_cpu_ms() {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return 1e3 * double(ts.tv_sec) + 1e-6 * double(ts.tv_nsec);
}

double percentile(std::vector<double> v, double p) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    return v[std::min(v.size() - 1, std::size_t(p * double(v.size() - 1) + 0.5))];
}

} // namespace

int main(int argc, char **argv) {
    const std::string method = argc > 1 ? argv[1] : "pt";
    const std::string base = method.substr(0, method.find('+'));
    const auto has = [&method](const char *suffix) {
        return method.find(std::string("+") + suffix) != std::string::npos;
    };
    const std::uint32_t width = argc > 3 ? std::uint32_t(std::atoi(argv[2])) : 320;
    const std::uint32_t height = argc > 3 ? std::uint32_t(std::atoi(argv[3])) : 180;
    const double budget_ms = argc > 4 ? std::atof(argv[4]) : 30.0;
    const int frames = argc > 5 ? std::atoi(argv[5]) : 120;
    const std::uint64_t units = argc > 6 ? std::strtoull(argv[6], nullptr, 10) : 0;
    constexpr std::uint32_t workers = 2;
    cmlt::Estimator estimator = base == "bdpt"  ? cmlt::Estimator::Bdpt
                                : base == "mlt"  ? cmlt::Estimator::Mlt
                                : base == "cmlt" ? cmlt::Estimator::Cmlt
                                                 : cmlt::Estimator::Pt;
    const bool metropolis = estimator == cmlt::Estimator::Mlt || estimator == cmlt::Estimator::Cmlt;

    cmlt_allocator allocator{nullptr, count_alloc, count_free};
    if (cmlt_set_allocator(&allocator) != CMLT_OK) return 1;

    // The room: 10 × 3 × 10, walls of 16 × 16 quads facing inwards.
    const int n = 16;
    std::vector<Mesh> walls = {
        grid({-5, 0, -5}, {0, 0, 10}, {10, 0, 0}, n), // floor (+y)
        grid({-5, 3, -5}, {10, 0, 0}, {0, 0, 10}, n), // ceiling (−y)
        grid({-5, 0, 5}, {0, 3, 0}, {10, 0, 0}, n),   // far wall (−z)
        grid({-5, 0, -5}, {10, 0, 0}, {0, 3, 0}, n),  // near wall (+z)
        grid({-5, 0, -5}, {0, 3, 0}, {0, 0, 10}, n),  // left wall (+x)
        grid({5, 0, -5}, {0, 0, 10}, {0, 3, 0}, n),   // right wall (−x)
    };
    // Over the far half of the room: in view all along the dolly.
    Mesh light = grid({-1, 2.99f, 1.5f}, {2, 0, 0}, {0, 0, 2}, 1);
    Mesh ball_a = sphere(-2.0f, 0.8f, 2.0f, 0.8f, 12, 24);
    Mesh ball_b = sphere(2.0f, 0.6f, 0.5f, 0.6f, 12, 24);
    Mesh mover = sphere(0.0f, 0.5f, 1.0f, 0.5f, 16, 32);
    std::vector<float> moved = mover.positions;

    cmlt::Scene scene;
    check(cmlt::Scene::create(scene), "cmlt_scene_new");
    std::uint32_t white, red, green;
    check(scene.add_material(diffuse(0.7f, 0.7f, 0.7f), white), "add_material");
    check(scene.add_material(diffuse(0.7f, 0.15f, 0.1f), red), "add_material");
    check(scene.add_material(diffuse(0.1f, 0.6f, 0.15f), green), "add_material");
    for (std::size_t i = 0; i < walls.size(); ++i) add(scene, walls[i], i == 4 ? red : i == 5 ? green : white);
    add(scene, light, white, 12.0f);
    add(scene, ball_a, white);
    add(scene, ball_b, red);
    add(scene, mover, green);
    const std::uint32_t mover_id = std::uint32_t(walls.size()) + 3;
    check(scene.commit(), "cmlt_scene_commit");
    std::uint32_t triangles = 0;
    check(cmlt::Status(cmlt_scene_triangle_count(scene.get(), &triangles)), "triangle_count");

    cmlt_renderer_config config = cmlt::config_default(estimator);
    config.width = width;
    config.height = height;
    config.workers = workers;
    config.max_depth = 5;
    if (metropolis) {
        config.keep_chains = 1;
        // b tracked from the chains' large steps of the last 32 frames:
        // the dolly changes the image's mean and a bootstrap spans tens
        // of frames (one frame's large steps are too noisy alone).
        config.large_step_window = 32;
        // One normalisation pass per bootstrap: after the first, each is
        // evaluated in the frames' set-up slices (b tracked over them).
        config.normalisation_passes = 1;
        config.normalisation_min_samples = 0;
    }
    cmlt_camera camera{{0.0f, 1.5f, -4.5f}, {0.0f, 1.2f, 3.0f}, {0.0f, 1.0f, 0.0f}, 70.0f, 0.0f, 1.0f};
    cmlt::Renderer renderer;
    check(cmlt::Renderer::create(scene, config, camera, renderer), "cmlt_renderer_new");
    if (has("keep")) check(renderer.set_accumulation(cmlt::Accumulation::Keep), "set_accumulation");
    if (has("decay")) check(renderer.set_accumulation(cmlt::Accumulation::Decay, 0.8f), "set_accumulation");
    if (!has("full")) check(renderer.set_pixel_block(cmlt::pixel_block_fit), "set_pixel_block");
    std::vector<float> image(std::size_t(width) * height * 3);
    // Rendering stops this long before the frame's end, for the resolve:
    // the last resolve's time and a millisecond of margin.
    double reserve_ms = 1.0;

    std::vector<double> frame_ms, setup_ms, setup_cpu_ms, black, means, cpu_ms;
    const unsigned long before = g_allocations.load();
    for (int f = 0; f < frames; ++f) {
        const auto t0 = Clock::now();
        const auto deadline = t0 + std::chrono::duration<double, std::milli>(budget_ms - reserve_ms);
        auto keep_going = [deadline, units](std::uint64_t done) {
            return units > 0 ? done < units : Clock::now() < deadline;
        };
        // The dolly: 2 cm forwards a frame; the green ball slides sideways.
        camera.position[2] = -4.5f + 0.02f * float(f);
        check(renderer.set_camera(camera), "set_camera");
        const float dx = 1.5f * std::sin(0.05f * float(f));
        for (std::size_t v = 0; v < moved.size(); v += 3) moved[v] = mover.positions[v] + dx;
        check(scene.update_mesh(mover_id, moved.data(), moved.size() / 3), "update_mesh");

        // The set-up: the first frame's runs to the end (the level load);
        // later frames give it 5 % of the budget. With kept chains the
        // renderer is ready whatever the set-up got done; otherwise the
        // frame waits for it. Each worker runs its set-up and its render
        // on one thread — worker 0 on this one, as an engine's main thread
        // takes a share of its jobs — and the two meet in between, where
        // the last to arrive joins the shares: every thread start and
        // wake-up is a chance for the scheduler to hold a thread back.
        const auto s0 = Clock::now();
        const auto setup_end = s0 + std::chrono::duration<double, std::milli>(0.05 * budget_ms);
        auto setup_going = [&](std::uint64_t) { return f == 0 || Clock::now() < setup_end; };
        bool pending = false;
        check(renderer.prepare_begin(pending), "prepare_begin");
        const auto b1 = Clock::now();
        double workers_ms = 0.0, finish_ms = 0.0;
        Clock::time_point s1;
        Meeting meeting{int(workers)};
        cmlt::Status finish_status = cmlt::Status::Ok;
        std::array<cmlt::Status, workers> setup_st{}, render_st{};
        std::array<double, workers> worker_cpu{}, worker_setup_cpu{};
        auto work = [&](std::uint32_t w) {
            const double c0 = thread_cpu_ms();
            if (pending) {
                bool finished = false;
                setup_st[w] = renderer.prepare_worker_while(w, setup_going, finished);
            }
            meeting.arrive([&] {
                const auto w1 = Clock::now();
                workers_ms = std::chrono::duration<double, std::milli>(w1 - b1).count();
                // A first bootstrap must be complete before anything renders:
                // the first frame's set-up runs to the end, so it is.
                if (pending) finish_status = renderer.prepare_finish();
                s1 = Clock::now();
                finish_ms = std::chrono::duration<double, std::milli>(s1 - w1).count();
            });
            worker_setup_cpu[w] = thread_cpu_ms() - c0;
            if (finish_status == cmlt::Status::Ok) render_st[w] = renderer.render_while(w, UINT64_MAX, keep_going);
            worker_cpu[w] = thread_cpu_ms() - c0;
        };
        {
            std::array<std::thread, workers - 1> threads;
            for (std::uint32_t w = 1; w < workers; ++w) threads[w - 1] = std::thread(work, w);
            work(0);
            for (auto &t : threads) t.join();
        }
        for (auto st : setup_st) check(st, "prepare_worker_while");
        check(finish_status, "prepare_finish");
        for (auto st : render_st) check(st, "render_while");
        const double setup = std::chrono::duration<double, std::milli>(s1 - s0).count();
        const auto r0 = Clock::now();
        const double render = std::chrono::duration<double, std::milli>(r0 - s1).count();
        const double resolve_cpu0 = thread_cpu_ms();
        check(renderer.resolve(cmlt::Format::Rgb32f, image.data(), 0, image.size() * sizeof(float)), "resolve");
        const double cpu = *std::max_element(worker_cpu.begin(), worker_cpu.end()) + thread_cpu_ms() - resolve_cpu0;
        reserve_ms = 1.0 + std::chrono::duration<double, std::milli>(Clock::now() - r0).count();
        const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();

        std::size_t dark = 0;
        double sum = 0.0;
        for (std::size_t i = 0; i < image.size(); i += 3) {
            double y = 0.2126 * image[i] + 0.7152 * image[i + 1] + 0.0722 * image[i + 2];
            dark += image[i] == 0.0f && image[i + 1] == 0.0f && image[i + 2] == 0.0f;
            sum += y;
        }
        const double mean = sum / double(width * height);
        frame_ms.push_back(ms);
        cpu_ms.push_back(cpu);
        if (f > 0) {
            setup_ms.push_back(setup);
            setup_cpu_ms.push_back(*std::max_element(worker_setup_cpu.begin(), worker_setup_cpu.end()));
        }
        black.push_back(double(dark) / double(width * height));
        means.push_back(mean);
        cmlt_stats stats{};
        check(renderer.stats(stats), "stats");
        std::printf("frame %d ms %.2f setup_ms %.2f mean %.5f black %.4f samples %llu update_ms %.2f render_ms %.2f resolve_ms %.2f "
                    "setup_begin_ms %.2f setup_workers_ms %.2f setup_finish_ms %.2f cpu_ms %.2f cpu0_ms %.2f "
                    "cpu1_ms %.2f\n",
                    f, ms, setup, mean, black.back(), static_cast<unsigned long long>(stats.samples), std::chrono::duration<double, std::milli>(s0 - t0).count(),
                    render, reserve_ms - 1.0, std::chrono::duration<double, std::milli>(b1 - s0).count(), workers_ms,
                    finish_ms, cpu, worker_cpu[0], worker_cpu[1]);
    }
    const unsigned long allocations = g_allocations.load() - before;

    double flicker = 0.0;
    int pairs = 0;
    for (std::size_t f = 1; f < means.size(); ++f) {
        double a = means[f - 1], b = means[f];
        double rel = a + b > 0.0 ? (b - a) / (0.5 * (a + b)) : 0.0;
        flicker += rel * rel;
        ++pairs;
    }
    flicker = pairs > 0 ? std::sqrt(flicker / pairs) : 0.0;
    double setup_mean = 0.0;
    for (double s : setup_ms) setup_mean += s;
    setup_mean = setup_ms.empty() ? 0.0 : setup_mean / double(setup_ms.size());
    int over = 0;
    double over_lost = 0.0;
    for (std::size_t f = 1; f < frame_ms.size(); ++f)
        if (frame_ms[f] > 1.1 * budget_ms) {
            ++over;
            over_lost += frame_ms[f] - cpu_ms[f];
        }
    over_lost = over > 0 ? over_lost / double(over) : 0.0;
    double setup_cpu_mean = 0.0;
    for (double s : setup_cpu_ms) setup_cpu_mean += s;
    setup_cpu_mean = setup_cpu_ms.empty() ? 0.0 : setup_cpu_mean / double(setup_cpu_ms.size());
    double black_mean = 0.0;
    for (double b : black) black_mean += b;
    black_mean /= double(std::max<std::size_t>(black.size(), 1));
    std::printf("trial %s %ux%u triangles %u budget_ms %.1f frames %d p50_ms %.2f p95_ms %.2f setup_ms %.2f "
                "setup_p50_ms %.2f black %.4f flicker %.4f allocs_per_frame %.2f cpu_p50_ms %.2f cpu_p95_ms %.2f "
                "over %d over_lost_ms %.2f setup_cpu_ms %.2f\n",
                method.c_str(), width, height, triangles, budget_ms, frames, percentile(frame_ms, 0.5),
                percentile(frame_ms, 0.95), setup_mean, percentile(setup_ms, 0.5), black_mean, flicker,
                double(allocations) / double(std::max(frames, 1)), percentile(cpu_ms, 0.5), percentile(cpu_ms, 0.95),
                over, over_lost, setup_cpu_mean);
    return 0;
}
