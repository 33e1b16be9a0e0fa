# Third-party dependencies, found the way ../shared/STACK.md verified on Debian 12.
# Only what the stages built need is looked up here.

find_package(PkgConfig REQUIRED)
find_package(Threads REQUIRED)
if(CITYATLAS_MIMALLOC)
  find_package(mimalloc CONFIG REQUIRED)  # Debian: libmimalloc-dev (mimalloc 2.0)
endif()

# The client and the format library need only what follows the pipeline's
# block; CITYATLAS_PIPELINE=OFF skips the pipeline's (GDAL, PROJ, CGAL, ...).
if(CITYATLAS_PIPELINE)
# OpenImageIO: Debian's config names /usr/include/opencv4, which does not exist
# unless libopencv-dev happens to be installed; point the target at /usr/include.
find_package(OpenImageIO CONFIG REQUIRED)
set_target_properties(OpenImageIO::OpenImageIO PROPERTIES
  INTERFACE_INCLUDE_DIRECTORIES "/usr/include"
  INTERFACE_SYSTEM_INCLUDE_DIRECTORIES "")

find_package(GDAL CONFIG REQUIRED)
find_package(PROJ CONFIG REQUIRED)
find_package(CGAL CONFIG REQUIRED)
find_package(TBB CONFIG REQUIRED)
find_package(LibXml2 REQUIRED)
# Debian's tinygltf: the tests read our glTF back with it (it has no Draco;
# keep it out of libraries that link Draco, see ../shared/STACK.md).
find_package(TinyGLTF CONFIG REQUIRED)
# GeographicLib ships a Find module, not a config, off CMake's default path.
list(APPEND CMAKE_MODULE_PATH /usr/share/cmake/geographiclib)
find_package(GeographicLib REQUIRED)

find_package(meshoptimizer CONFIG REQUIRED)
# Build-time ray casting (atlas/raycast.h: computed textures); the target is `embree`.
find_package(embree 3 CONFIG REQUIRED)
# The sun's position (atlas/sun_hours.h); libnova ships neither a config nor a .pc file.
find_path(NOVA_INCLUDE_DIR libnova/solar.h REQUIRED)
find_library(NOVA_LIBRARY nova REQUIRED)
add_library(nova::nova UNKNOWN IMPORTED)
set_target_properties(nova::nova PROPERTIES IMPORTED_LOCATION ${NOVA_LIBRARY} INTERFACE_INCLUDE_DIRECTORIES ${NOVA_INCLUDE_DIR})
# tileset.json validation in `cityatlas inspect` (header-only).
find_package(valijson CONFIG REQUIRED)
# The 3D Tiles export's WebP images: libwebp itself, in memory and at its default
# effort (OpenImageIO's WebP writer works through a file at the slowest method, 6).
pkg_check_modules(WEBP REQUIRED IMPORTED_TARGET libwebp)
endif()

# Both sides: JSON, messages, the command line.
# Content hashes for `build`, the BlockMap file's checksum (format/blockmap_file.h).
pkg_check_modules(XXHASH REQUIRED IMPORTED_TARGET libxxhash)
# BlockMap planes (format/blockmap_file.h). Debian: libzstd-dev.
find_package(zstd CONFIG REQUIRED)
find_package(nlohmann_json 3 CONFIG REQUIRED)
find_package(CLI11 CONFIG REQUIRED)
find_package(fmt CONFIG REQUIRED)

# S3TC (stb_dxt encodes, compiled in Debian's libstb; libsquish encodes and
# decodes) and Draco geometry (../shared/STACK.md); the client decodes both.
pkg_check_modules(STB REQUIRED IMPORTED_TARGET stb)
# libsquish's .pc file has an empty prefix: find it by hand.
find_path(SQUISH_INCLUDE_DIR squish.h REQUIRED)
find_library(SQUISH_LIBRARY squish REQUIRED)
add_library(squish::squish UNKNOWN IMPORTED)
set_target_properties(squish::squish PROPERTIES IMPORTED_LOCATION ${SQUISH_LIBRARY}
                      INTERFACE_INCLUDE_DIRECTORIES ${SQUISH_INCLUDE_DIR})
find_package(draco CONFIG REQUIRED)

# render: OpenGL 3.3 core through libepoxy; EGL surfaceless for headless
# rendering (Mesa llvmpipe, no display), GLFW for the window; libcurl fetches
# tiles over HTTP; `serve` answers them with Boost.Beast over Boost.Asio
# (header-only, in libboost-dev); cpp-httplib is only the loader tests'
# in-process server (Debian ships its compiled build: link through pkg-config
# so the ABI defines match); Dear ImGui's static library carries the GLFW and
# OpenGL3 backends.
set(OpenGL_GL_PREFERENCE GLVND)
find_package(OpenGL REQUIRED COMPONENTS OpenGL EGL)
find_package(glfw3 3.3 CONFIG REQUIRED)
pkg_check_modules(EPOXY REQUIRED IMPORTED_TARGET epoxy)
find_package(CURL REQUIRED)
find_package(Boost 1.74 REQUIRED)  # Boost::headers: Beast, Asio
pkg_check_modules(HTTPLIB REQUIRED IMPORTED_TARGET cpp-httplib)
pkg_check_modules(IMGUI REQUIRED IMPORTED_TARGET imgui)

if(CITYATLAS_BUILD_TESTS AND CITYATLAS_PIPELINE)
  find_package(GTest CONFIG REQUIRED)
  include(GoogleTest)
endif()
