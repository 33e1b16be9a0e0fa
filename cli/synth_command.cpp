// SPDX-License-Identifier: GPL-3.0-or-later
// `cityatlas synth`: write a synthetic town (CityGML 2.0, footprint shapefile,
// PNG textures, truth.json) and show the Scene it ingests to.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <map>
#include <string>
#include <vector>

#include <cpl_conv.h>
#include <ogr_spatialref.h>

#include <fmt/format.h>

#include "cli/commands.h"
#include "cli/outcome.h"
#include "cli/progress.h"
#include "ingest/crs.h"
#include "ingest/synth/town.h"
#include "ingest/synth/write_town.h"

namespace cityatlas::cli {
namespace fs = std::filesystem;
namespace {

struct SynthOptions {
    synth::TownSettings town;
    std::vector<double> origin;  // E,N[,H] when given
    bool extreme = false;
    std::string out_dir;
    bool overwrite = false;
    bool quiet = false;
};

// Default CRS and its default origin (Munich, in ETRS89 / UTM 32N).
constexpr int kDefaultCrs = 25832;
constexpr double kDefaultOrigin[3] = {690000, 5336000, 500};
// --extreme: a real place with extreme grid coordinates: just south of the
// equator in UTM zone 33S the false northing makes northings ~9.9e6 m, and
// 833 km easting is at the zone's eastern edge.
constexpr int kExtremeCrs = 32733;
constexpr double kExtremeOrigin[3] = {833000, 9900000, 0};

// The centre of a CRS's area of use, in its own coordinates, rounded to whole
// metres (so the town's exact coordinates stay exact).
Status areaOfUseCentre(int epsg, Vec3d* centre) {
    OGRSpatialReference srs;
    if (srs.importFromEPSG(epsg) != OGRERR_NONE) return Status::Usage(fmt::format("EPSG:{} is unknown", epsg));
    double west = 0, south = 0, east = 0, north = 0;
    const char* area_name = nullptr;
    if (!srs.GetAreaOfUse(&west, &south, &east, &north, &area_name))
        return Status::Usage(fmt::format("EPSG:{} has no area of use; give --origin", epsg));
    if (east < west) east += 360;  // crosses the antimeridian
    double lon = (west + east) / 2, lat = (south + north) / 2;
    if (lon > 180) lon -= 360;
    OGRSpatialReference wgs84;
    wgs84.SetWellKnownGeogCS("WGS84");
    wgs84.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    srs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    std::unique_ptr<OGRCoordinateTransformation> ct(OGRCreateCoordinateTransformation(&wgs84, &srs));
    if (!ct || !ct->Transform(1, &lon, &lat))
        return Status::Usage(fmt::format("cannot transform the centre of EPSG:{}'s area of use; give --origin", epsg));
    *centre = {std::round(lon), std::round(lat), 0};
    return Status::Ok();
}

int runSynth(const SynthOptions& opt_in) {
    SynthOptions opt = opt_in;
    const auto t0 = std::chrono::steady_clock::now();
    if (opt.extreme && !opt.origin.empty()) {
        return fail("synth", Status::Usage("--extreme and --origin both place the town; give one"));
    }
    CrsInfo crs;
    if (Status s = requireProjectedMetricCrs(opt.town.crs_epsg, &crs); !s.ok()) {
        return fail("synth", Status::Usage("--crs: " + s.error));
    }
    if (!opt.origin.empty()) {
        if (opt.origin.size() < 2 || opt.origin.size() > 3) {
            return fail("synth", Status::Usage("--origin takes E,N or E,N,H"));
        }
        for (double& v : opt.origin) {
            if (!std::isfinite(v) || std::abs(v) > 6.7e7) {  // 2^26 m keeps every coordinate exact
                return fail("synth", Status::Usage("--origin: coordinates must be finite and within 6.7e7 m"));
            }
            if (v != std::round(v)) {
                note("synth", "--origin: rounding " + synth::exactDecimal(v) + " to whole metres");
                v = std::round(v);
            }
        }
        opt.town.origin_source = {opt.origin[0], opt.origin[1], opt.origin.size() > 2 ? opt.origin[2] : 0.0};
    } else if (opt.extreme) {
        opt.town.origin_source = {kExtremeOrigin[0], kExtremeOrigin[1], kExtremeOrigin[2]};
    } else if (opt.town.crs_epsg == kDefaultCrs) {
        opt.town.origin_source = {kDefaultOrigin[0], kDefaultOrigin[1], kDefaultOrigin[2]};
    } else if (Status s = areaOfUseCentre(opt.town.crs_epsg, &opt.town.origin_source); !s.ok()) {
        return fail("synth", Status::Usage(s.error));
    }

    Progress progress(!opt.quiet);
    if (!opt.quiet) progress.update("generating town", 0, 1);
    const synth::Town town = synth::generateTown(opt.town);
    const Status written = synth::writeTown(town, opt.out_dir, opt.overwrite,
                                            [&](const char* step, uint64_t done, uint64_t total) {
                                                progress.update(step, done, total);
                                            });
    if (!written.ok()) return fail("synth", written, &progress);
    const double write_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

    // "Ingest" the town: the Scene every later stage consumes.
    if (!opt.quiet) progress.update("building scene", 0, 1);
    const Scene scene = synth::townToScene(town, fs::absolute(opt.out_dir));
    const SceneStats stats = computeStats(scene);
    progress.finish();
    const double total_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

    uint64_t texture_bytes = 0;
    for (const auto& t : town.textures) texture_bytes += fs::file_size(fs::path(opt.out_dir) / t.relative_path);
    auto size = [&](const char* name) { return humanBytes(fs::file_size(fs::path(opt.out_dir) / name)); };
    const Vec3d o = opt.town.origin_source;
    std::printf("Synthetic town: %u buildings, LOD%d, seed %llu, %s (EPSG:%d), origin %s %s %s\n",
                opt.town.buildings, opt.town.lod, static_cast<unsigned long long>(opt.town.seed), crs.name.c_str(),
                opt.town.crs_epsg, synth::exactDecimal(o.x).c_str(), synth::exactDecimal(o.y).c_str(),
                synth::exactDecimal(o.z).c_str());
    std::printf("Written to %s/\n", fs::absolute(opt.out_dir).lexically_normal().string().c_str());
    std::printf("  %-18s %10s  CityGML 2.0\n", synth::kCityGmlName, size(synth::kCityGmlName).c_str());
    std::printf("  %-18s %10s  footprints with attributes (+ .shx .dbf .prj .cpg)\n", synth::kShapefileName,
                size(synth::kShapefileName).c_str());
    std::printf("  %-18s %10s  %zu PNG textures, %dx%d px\n", "textures/", humanBytes(texture_bytes).c_str(),
                town.textures.size(), opt.town.texture_size_px, opt.town.texture_size_px);
    if (town.orthophoto_texture >= 0)
        std::printf("  %-18s %10s  orthophoto %dx%d px, %s m pixels, on every roof (%s)\n", "", "",
                    town.orthophoto.width_px, town.orthophoto.height_px,
                    synth::exactDecimal(town.orthophoto.pixel_m).c_str(),
                    opt.town.orthophoto == synth::OrthophotoMode::WorldFile ? "world file orthophoto.pgw"
                                                                            : "referencePoint + orientation");
    std::printf("  %-18s %10s  ground truth for tests\n", synth::kTruthName, size(synth::kTruthName).c_str());
    std::printf("Scene (textured triangle soup, local metres around the origin):\n");
    std::printf("  %zu triangles (%zu textured), %zu features, %zu textures, %zu materials\n", stats.triangles,
                stats.textured_triangles, stats.features, stats.textures, scene.materials.size());
    for (int k = 0; k < kSurfaceSemanticCount; ++k) {
        if (stats.triangles_by_semantic[k] == 0) continue;
        std::printf("  %-8s %9zu triangles %14.2f m2\n",
                    std::string(semanticName(static_cast<SurfaceSemantic>(k))).c_str(), stats.triangles_by_semantic[k],
                    stats.area_by_semantic_m2[k]);
    }
    const Box3d& b = stats.bounds_local;
    std::printf("  bounds (local m): x %.3f .. %.3f, y %.3f .. %.3f, z %.3f .. %.3f\n", b.min.x, b.max.x, b.min.y,
                b.max.y, b.min.z, b.max.z);
    std::printf("Time %.2f s (files %.2f s), peak memory %s\n", total_s, write_s, humanBytes(peakRssBytes()).c_str());
    return kExitOk;
}

}  // namespace

RunFn addSynthCommand(CLI::App& app) {
    auto opt = std::make_shared<SynthOptions>();
    opt->town.crs_epsg = kDefaultCrs;
    CLI::App* cmd = app.add_subcommand(
        "synth",
        "Generate a synthetic town with exact ground truth: CityGML 2.0 (LOD1 or LOD2, textured), a footprint\n"
        "shapefile of the same buildings, PNG textures (each facade shows its building number) and truth.json.\n"
        "Same options, same seed: byte-identical files.");
    cmd->add_option("--buildings", opt->town.buildings, "Number of buildings")
        ->default_val(100)
        ->check(CLI::Range(1u, 10000000u));
    cmd->add_option("--lod", opt->town.lod, "Level of detail: 1 = flat blocks (lod1Solid), 2 = roofs and thematic surfaces")
        ->default_val(2)
        ->check(CLI::IsMember({1, 2}));
    cmd->add_option("--seed", opt->town.seed, "Random seed")->default_val(1);
    cmd->add_option("--texture-size", opt->town.texture_size_px, "Facade and paving texture size, pixels (square)")
        ->default_val(512)
        ->check(CLI::Range(16, 8192));
    cmd->add_option("--crs", opt->town.crs_epsg,
                    "EPSG code of a projected CRS in metres (default 25832, ETRS89 / UTM 32N; 32733 with --extreme)");
    cmd->add_option("--origin", opt->origin,
                    "Town centre E,N[,H] in CRS units (default: Munich for EPSG:25832, else the centre of the CRS's area "
                    "of use)")
        ->delimiter(',')
        ->expected(2, 3);
    cmd->add_flag("--extreme", opt->extreme,
                  "Place the town at extreme grid coordinates: E 833000, N 9900000 (UTM 33S, just south of the equator)");
    static const std::map<std::string, synth::OrthophotoMode> orthophoto_modes = {
        {"none", synth::OrthophotoMode::None},
        {"world-file", synth::OrthophotoMode::WorldFile},
        {"reference-point", synth::OrthophotoMode::ReferencePoint}};
    cmd->add_option("--orthophoto", opt->town.orthophoto,
                    "Texture every roof with one orthophoto of the town (textures/orthophoto.png, 0.25 m pixels, each "
                    "roof's pixels in a colour that encodes its building number) as a CityGML GeoreferencedTexture "
                    "placed by a world file (textures/orthophoto.pgw) or by referencePoint + orientation; none: paving "
                    "and colours")
        ->transform(CLI::CheckedTransformer(orthophoto_modes))
        ->default_str("none");
    cmd->add_option("-o,--output", opt->out_dir, "Output folder (must not exist unless --overwrite)")->required();
    cmd->add_flag("--overwrite", opt->overwrite, "Replace an existing output folder");
    cmd->add_flag("-q,--quiet", opt->quiet, "No progress on stderr");
    return [opt, cmd]() {
        SynthOptions o = *opt;
        // --extreme without --crs switches to the zone where such northings are real.
        if (o.extreme && cmd->count("--crs") == 0) o.town.crs_epsg = kExtremeCrs;
        return runSynth(o);
    };
}

}  // namespace cityatlas::cli
