// make_phantom.cpp: writes the built-in phantom as a raw file laid out like CThead, so any
// tool that reads CThead (or `--volume FILE --dims 256,256,113`) can read it too.
//
//   build/make_phantom OUT.raw
//
// OUT.raw: 256 x 256 x 113 signed 16-bit little-endian values, no header, i fastest
// (cthead[k][j][i]), 14,811,136 bytes. What is in it: handouts/phantom.md.
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>
#include <thread>
#include <vector>
#include "error.h"
#include "phantom.h"
#include "render.h"
#include "step.h"

using namespace ctlab;

constexpr const char* tool_name = "make_phantom";
constexpr const char* usage = "usage: make_phantom OUT.raw";

// Little-endian on every machine: low byte first.
static void write_raw(const Volume& volume, const std::string& path) {
    const std::vector<int16_t> values = dense_values(volume);  // no padding in files
    std::vector<unsigned char> bytes(values.size() * 2);
    for (size_t n = 0; n < values.size(); ++n) {
        const uint16_t bits = static_cast<uint16_t>(values[n]);
        bytes[2 * n] = static_cast<unsigned char>(bits & 0xff);
        bytes[2 * n + 1] = static_cast<unsigned char>(bits >> 8);
    }
    FILE* file = std::fopen(path.c_str(), "wb");
    if (!file) throw InputError("cannot write '" + path + "': " + std::strerror(errno));
    const bool written = std::fwrite(bytes.data(), 1, bytes.size(), file) == bytes.size();
    if (std::fclose(file) != 0 || !written) {
        throw InputError("cannot write '" + path + "': " + std::strerror(errno));
    }
}

int main(int argc, char** argv) {
    return guarded_main(tool_name, [&] {
        if (argc == 2 && (std::strcmp(argv[1], "--help") == 0 ||
                          std::strcmp(argv[1], "-h") == 0)) {
            std::printf("%s\nWrites the built-in CT head phantom as a raw CThead-style file.\n",
                        usage);
            return 0;
        }
        if (argc != 2 || argv[1][0] == '-' || argv[1][0] == '\0') {
            throw InputError(std::string("expected one output file name; ") + usage);
        }
        const std::string path = argv[1];

        const Timer timer;
        const unsigned cores = std::thread::hardware_concurrency();  // 0: unknown
        // Painted on every core: the voxels are the same however many threads paint them.
        const Volume volume = make_phantom(cores > 0 ? int(cores) : 1);
        const double generate_ms = timer.ms();
        write_raw(volume, path);

        std::printf("%s: %s: %d x %d x %d int16 little-endian, spacing %g:%g:%g, "
                    "min %d, max %d, %zu bytes (generated in %.0f ms)\n",
                    tool_name, path.c_str(), volume.nx, volume.ny, volume.nz, volume.sx,
                    volume.sy, volume.sz, volume.min_value, volume.max_value,
                    volume.voxel_count() * 2, generate_ms);
        return 0;
    });
}
