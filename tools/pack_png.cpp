// pack_png.cpp: rewrites PNG files at the default compression, pixels unchanged. A step's
// --debug-pixel writes its ray pictures uncompressed (common/image.h: cheap for a run that
// opens them once); make reference stores them in the repository, where a picture that is
// 70 times bigger for nothing costs every clone. tools/make_reference.sh runs this on each.
//
//   build/pack_png FILE...
//
// Each file is read, written again beside itself and renamed into place (write_png), then
// read back and compared (tools/compare.h: no channel may differ). Exits 0, or 2 with one
// line naming the file.
#include <cstdio>
#include <string>
#include "error.h"
#include "image.h"
#include "tools/compare.h"
#include "tools/image_read.h"

int main(int argc, char** argv) {
    if (argc == 2 && (std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h")) {
        std::printf("usage: pack_png FILE...\nRewrites each PNG at the default compression, "
                    "its pixels unchanged (make reference runs it).\n");
        return 0;
    }
    if (argc < 2) {
        std::fprintf(stderr, "usage: pack_png FILE...\n");
        return ctlab::exit_bad_input;
    }
    try {
        for (int a = 1; a < argc; ++a) {
            const std::string path = argv[a];
            const ctlab::Image image = ctlab::read_image_file(path, false);
            ctlab::write_png(image, path);
            const ctlab::Image written = ctlab::read_image_file(path, false);
            if (ctlab::compare_images(written, image, 0, path, path).max_abs != 0)
                throw ctlab::InputError(path + ": its pixels changed when written again");
        }
        return 0;
    } catch (const std::exception& error) {
        std::fprintf(stderr, "pack_png: error: %s\n", error.what());
        return ctlab::exit_bad_input;
    }
}
