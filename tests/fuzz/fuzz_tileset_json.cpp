// SPDX-License-Identifier: GPL-3.0-or-later
// libFuzzer target for the client's tileset.json reader (format/tileset_index):
// any bytes give a Status or an index, never a crash, a hang or a sanitizer
// report; and an index it accepts must be safe for what the client does next
// on open and on its first frame (budget check, block manager, default camera
// path, classification, selection).
#include <cstdint>
#include <string>

#include "render/core/block_manager.h"
#include "render/core/camera_path.h"
#include "render/core/selection.h"
#include "render/core/tileset_index.h"
#include "tests/fuzz/fuzz_support.h"

using namespace cityatlas;
using namespace cityatlas::render;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
    TilesetIndex index;
    if (!parseTilesetIndex(text, "fuzz/tileset.json", &index).ok()) {
        if (!index.nodes.empty() || !index.blocks.empty()) __builtin_trap();  // a refused index is left empty
        return 0;
    }
    if (index.nodes.empty()) __builtin_trap();  // accepted: there is a root
    constexpr uint64_t kBudget = 512ull << 20;
    if (!BlockManager::checkBudget(index, kBudget).ok()) return 0;  // StreamingClient::open stops here
    BlockManager manager(index, BudgetParams{kBudget, 16});
    const CameraPath path = defaultPath(index.nodes[0].bounds);
    for (const size_t frame : {size_t{0}, path.frameCount() / 2}) {
        const CameraSample s = sampleFrame(path, frame);
        Camera camera;
        camera.position = s.position;
        camera.direction = s.direction;
        camera.vertical_fov_deg = s.fov_deg;
        SelectionParams params;
        const Classification c = classifyBlocks(index, camera, params);
        const BlockActions actions = manager.update(c);
        for (const BlockId b : actions.request) manager.finished(b, (b & 1) == 0);
        (void)selectDraws(index, camera, params, [&](BlockId b) { return manager.state(b) == BlockState::Resident; });
        (void)selectDraws(index, camera, params, [](BlockId) { return true; });
    }
    return 0;
}
