// BVH build time and primary-ray throughput on the Stanford bunny: a 1024×1024 pinhole camera
// framing the bunny (about 29 % of the rays hit it), one ray per pixel centre, traced in 16×16
// pixel tiles with 1 or 2 oneTBB threads. Reference point: Embree 3.13 single-ray kernels cast
// ~34 M such rays/s with 2 threads on the 2-core development machine and build in 20–30 ms.
//
// The bunny is found on $MRT_DATA (':'-separated), else in MRT_SOURCE_DIR/../shared/data.

#include "common/mesh/mesh_io.h"
#include "common/scene/scene.h"
#include "common/scene_io/data_path.h"
#include "common/scene_io/scene_loader.h"
#include "common/system/error.h"
#include "trace/bvh/scene_bvh.h"
#include "trace/bvh/triangle_bvh.h"
#include "trace/render/camera_rays.h"

#include <benchmark/benchmark.h>
#include <oneapi/tbb/blocked_range2d.h>
#include <oneapi/tbb/combinable.h>
#include <oneapi/tbb/global_control.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/task_arena.h>

#include <cmath>
#include <filesystem>
#include <string>

namespace mrt {
namespace {

constexpr int kImageSize = 1024;
constexpr int kTile = 16;

const Mesh& bunny() {
    static const Mesh mesh = [] {
        const std::string name = "meshes/stanford-bunny.obj";
        auto path = resolve_data_file(name, {});
        if (!path) {
            const std::filesystem::path fallback =
                std::filesystem::path(MRT_SOURCE_DIR) / ".." / "shared" / "data" / name;
            if (!std::filesystem::is_regular_file(fallback)) {
                throw Error(name + " not found on $MRT_DATA nor in " + fallback.string());
            }
            path = fallback;
        }
        return load_mesh(*path, 0).mesh;
    }();
    return mesh;
}

/// Looks at the bunny from the front (+z) with a 40° field of view, from a little closer than
/// where the bounding sphere of its box would just span the frame's height: 29 % of the pixels
/// see the bunny.
CameraRays framing_camera(const Eigen::AlignedBox3f& box) {
    Camera camera;
    camera.vertical_fov = 40.0f * kPi / 180.0f;
    const float radius = 0.5f * box.diagonal().norm();
    const float distance = 0.95f * radius / std::tan(0.5f * camera.vertical_fov);
    camera.look_at = box.center();
    camera.eye = box.center() + Vec3f(0.0f, 0.0f, distance);
    camera.up = Vec3f(0.0f, 1.0f, 0.0f);
    return CameraRays(camera, kImageSize, kImageSize);
}

void BM_BuildTriangleBvh(benchmark::State& state) {
    const Mesh& mesh = bunny();
    const tbb::global_control threads(tbb::global_control::max_allowed_parallelism,
                                      static_cast<std::size_t>(state.range(0)));
    std::size_t nodes = 0;
    for (auto _ : state) {
        const TriangleBvh bvh(mesh);
        nodes = bvh.nodes().size();
        benchmark::DoNotOptimize(nodes);
    }
    state.counters["triangles"] = static_cast<double>(mesh.triangles.size());
    state.counters["nodes"] = static_cast<double>(nodes);
    state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(mesh.triangles.size()));
}
BENCHMARK(BM_BuildTriangleBvh)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

/// Traces the whole image with `trace(ray) -> bool hit` on `threads` threads; returns hits.
template <typename Trace>
std::int64_t trace_image(const CameraRays& camera, tbb::task_arena& arena, const Trace& trace) {
    tbb::combinable<std::int64_t> hits([] { return std::int64_t{0}; });
    arena.execute([&] {
        tbb::parallel_for(
            tbb::blocked_range2d<int>(0, kImageSize, kTile, 0, kImageSize, kTile),
            [&](const tbb::blocked_range2d<int>& r) {
                std::int64_t local = 0;
                for (int y = r.rows().begin(); y != r.rows().end(); ++y) {
                    for (int x = r.cols().begin(); x != r.cols().end(); ++x) {
                        const Ray ray = camera.pinhole_ray(static_cast<float>(x) + 0.5f,
                                                           static_cast<float>(y) + 0.5f);
                        local += trace(ray) ? 1 : 0;
                    }
                }
                hits.local() += local;
            },
            tbb::simple_partitioner());
    });
    return hits.combine([](std::int64_t a, std::int64_t b) { return a + b; });
}

template <typename Trace>
void run_primary(benchmark::State& state, const Trace& trace, const CameraRays& camera) {
    tbb::task_arena arena(static_cast<int>(state.range(0)));
    std::int64_t hits = 0;
    for (auto _ : state) {
        hits = trace_image(camera, arena, trace);
        benchmark::DoNotOptimize(hits);
    }
    const std::int64_t rays = std::int64_t{kImageSize} * kImageSize;
    state.SetItemsProcessed(state.iterations() * rays);
    state.counters["rays/s"] = benchmark::Counter(static_cast<double>(state.iterations() * rays),
                                                  benchmark::Counter::kIsRate);
    state.counters["hit_fraction"] = static_cast<double>(hits) / static_cast<double>(rays);
}

void BM_PrimaryRaysTriangleBvh(benchmark::State& state) {
    const Mesh& mesh = bunny();
    const TriangleBvh bvh(mesh);
    const CameraRays camera = framing_camera(bvh.bounds());
    run_primary(
        state,
        [&](const Ray& ray) {
            TriangleHit hit;
            return bvh.intersect(ray, hit);
        },
        camera);
}
BENCHMARK(BM_PrimaryRaysTriangleBvh)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_PrimaryRaysSceneBvh(benchmark::State& state) {
    Scene scene;
    scene.meshes.push_back(bunny());
    scene.groups.resize(1);
    scene.groups[0].children.push_back({Instance::Kind::Mesh, 0, Affine3f::Identity()});
    const SceneBvh bvh(scene);
    const CameraRays camera = framing_camera(bvh.bounds());
    run_primary(
        state,
        [&](const Ray& ray) {
            SceneHit hit;
            return bvh.intersect(ray, hit);
        },
        camera);
}
BENCHMARK(BM_PrimaryRaysSceneBvh)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_OccludedPrimaryRays(benchmark::State& state) {
    const Mesh& mesh = bunny();
    const TriangleBvh bvh(mesh);
    const CameraRays camera = framing_camera(bvh.bounds());
    run_primary(
        state, [&](const Ray& ray) { return bvh.occluded(ray); }, camera);
}
BENCHMARK(BM_OccludedPrimaryRays)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

/// The default scene (the paper's Figure 6), loaded once.
const Scene& default_scene() {
    static const Scene scene =
        load_scene(std::filesystem::path(MRT_SOURCE_DIR) / "data/scenes/two-spheres.json");
    return scene;
}

void BM_BuildSceneBvhDefaultScene(benchmark::State& state) {
    const Scene& scene = default_scene();
    const tbb::global_control threads(tbb::global_control::max_allowed_parallelism,
                                      static_cast<std::size_t>(state.range(0)));
    for (auto _ : state) {
        const SceneBvh bvh(scene);
        benchmark::DoNotOptimize(bvh.stats().bytes);
    }
    state.counters["triangles"] = static_cast<double>(scene.unique_triangle_count());
}
BENCHMARK(BM_BuildSceneBvhDefaultScene)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_PrimaryRaysDefaultScene(benchmark::State& state) {
    const Scene& scene = default_scene();
    const SceneBvh bvh(scene);
    const CameraRays camera(scene.camera, kImageSize, kImageSize);
    run_primary(
        state,
        [&](const Ray& ray) {
            SceneHit hit;
            return bvh.intersect(ray, hit);
        },
        camera);
}
BENCHMARK(BM_PrimaryRaysDefaultScene)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace mrt

BENCHMARK_MAIN();
