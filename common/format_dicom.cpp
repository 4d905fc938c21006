// format_dicom.cpp: a DICOM series (a folder of slices) through GDCM (Debian libgdcm-dev).
// Slices are sorted by their position along the slice normal (the cross product of the two
// ImageOrientationPatient directions), never by file name or InstanceNumber; stored values
// times RescaleSlope plus RescaleIntercept give the file's units (Hounsfield for CT).
#include <dirent.h>
#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <algorithm>
#include <csignal>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <gdcmDataSet.h>
#include <gdcmImageReader.h>
#include <gdcmTrace.h>
#include "error.h"
#include "file_input.h"
#include "samples.h"
#include "formats.h"

namespace ctlab {

namespace {
constexpr size_t max_slices = 1 << 16;

struct Slice {
    std::string file;
    double position = 0;   // along the normal
    double origin[3] = {0, 0, 0};
};

bool sample_type_of(const gdcm::PixelFormat& format, SampleType* type) {
    switch (format.GetScalarType()) {
        case gdcm::PixelFormat::UINT8: *type = SampleType::uint8; return true;
        case gdcm::PixelFormat::INT8: *type = SampleType::int8; return true;
        case gdcm::PixelFormat::UINT12:
        case gdcm::PixelFormat::UINT16: *type = SampleType::uint16; return true;
        case gdcm::PixelFormat::INT12:
        case gdcm::PixelFormat::INT16: *type = SampleType::int16; return true;
        case gdcm::PixelFormat::UINT32: *type = SampleType::uint32; return true;
        case gdcm::PixelFormat::INT32: *type = SampleType::int32; return true;
        case gdcm::PixelFormat::FLOAT32: *type = SampleType::float32; return true;
        case gdcm::PixelFormat::FLOAT64: *type = SampleType::float64; return true;
        default: return false;
    }
}

// The attributes the pixel decoding relies on, checked before GDCM decodes (it asserts on
// some: BitsAllocated 12 over 16-bit data). Plain (not encapsulated) PixelData must hold
// every pixel: GDCM would fill a short one's tail with zeros. `expected`: the slice's bytes.
void check_pixels(const gdcm::ImageReader& reader, const std::string& what, unsigned columns,
                  unsigned rows, size_t expected) {
    const gdcm::DataSet& data_set = reader.GetFile().GetDataSet();
    const gdcm::Image& image = reader.GetImage();
    const gdcm::PixelFormat& format = image.GetPixelFormat();
    const unsigned allocated = format.GetBitsAllocated(), stored = format.GetBitsStored(),
                   high = format.GetHighBit();
    if (!(allocated == 8 || allocated == 16 || allocated == 32 || allocated == 64) ||
        stored == 0 || stored > allocated || high >= allocated) {
        throw InputError(what + ": BitsAllocated " + std::to_string(allocated) + ", BitsStored " +
                         std::to_string(stored) + ", HighBit " + std::to_string(high) +
                         " do not describe pixels ctlab can read (BitsAllocated 8, 16 or 32, "
                         "BitsStored and HighBit within it)");
    }
    if (image.GetBufferLength() != expected) {
        throw InputError(what + " holds " + std::to_string(image.GetBufferLength()) +
                         " bytes of pixels, expected " + std::to_string(expected));
    }
    const gdcm::Tag pixel_data(0x7fe0, 0x0010);
    if (!data_set.FindDataElement(pixel_data)) throw InputError(what + " has no PixelData");
    if (const gdcm::ByteValue* value = data_set.GetDataElement(pixel_data).GetByteValue()) {
        if (value->GetLength() < expected) {
            throw InputError(what + ": its PixelData has " + std::to_string(value->GetLength()) +
                             " bytes, " + std::to_string(columns) + " columns x " +
                             std::to_string(rows) + " rows need " + std::to_string(expected));
        }
    }
}

// check_pixels, then the pixels decoded into `pixels` (what a library says on stderr, such as
// libjpeg on a damaged JPEG slice, quoted in our line).
void decode_pixels(const gdcm::ImageReader& reader, const std::string& what, unsigned columns,
                   unsigned rows, SampleType type, std::vector<char>& pixels) {
    const size_t expected = size_t(columns) * rows * sample_size(type);
    check_pixels(reader, what, columns, rows, expected);
    pixels.resize(expected);
    bool decoded = false;
    const std::string said =
        capture_stderr([&] { decoded = reader.GetImage().GetBuffer(pixels.data()); });
    if (!decoded) {
        throw InputError(what + ": GDCM could not decode its pixels" +
                         (said.empty() ? std::string() : " (it said: " + said + ")"));
    }
}

// GDCM as Debian builds it keeps its assert()s, and a damaged file can reach one (found by
// `make fuzz`): abort, not an error we could catch. A damaged length field also makes it
// allocate what the field says (an 860-byte file took 900 MB and 33 s, found by `make fuzz`).
// So each file is read first in a child process, with its memory and time bounded; only a
// file the child read whole is read again here.
enum class ChildRead { ok, unreadable, damaged };
constexpr int read_ok = 0, read_failed = 3;  // the child's exit statuses (a sanitizer's is 1)
constexpr rlim_t child_memory_base = rlim_t(128) << 20;  // bytes beyond what we already use
constexpr rlim_t child_memory_per_file_byte = 16;        // GDCM's copies of a slice, with room
constexpr unsigned child_seconds = 60;                   // a slice reads in milliseconds

// The sanitizers reserve terabytes of address space: no address-space limit under them.
#if defined(__SANITIZE_ADDRESS__)
constexpr bool limit_child_memory = false;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool limit_child_memory = false;
#else
constexpr bool limit_child_memory = true;
#endif
#else
constexpr bool limit_child_memory = true;
#endif

// This process's address space in bytes (0 when unknown).
rlim_t address_space_in_use() {
    std::ifstream statm("/proc/self/statm");
    unsigned long long pages = 0;
    if (!(statm >> pages)) return 0;
    return rlim_t(pages) * rlim_t(sysconf(_SC_PAGESIZE));
}

// The last line a library wrote into `sink` (the child's stderr), "" when none.
std::string last_line(std::FILE* sink) {
    if (!sink) return "";
    std::rewind(sink);
    std::string said;
    char line[512];
    while (std::fgets(line, sizeof line, sink)) {
        std::string text = line;
        for (char& c : text) {
            if (static_cast<unsigned char>(c) < 32 || c == 127) c = ' ';
        }
        const size_t first = text.find_first_not_of(' ');
        if (first != std::string::npos) said = text.substr(first, text.find_last_not_of(' ') - first + 1);
    }
    return said.size() > 160 ? said.substr(0, 160) + "..." : said;
}

// The child reads the file and decodes its pixels (GDCM's asserts sit in both: a
// BitsAllocated of 12 over 16-bit data aborts in the decoding). Its stderr goes to `sink`,
// so that what a library said (libjpeg on a damaged JPEG slice) can be quoted in our line.
ChildRead read_in_child(const std::string& file, off_t file_bytes, std::FILE* sink) {
    const rlim_t memory = address_space_in_use() + child_memory_base +
                          child_memory_per_file_byte * rlim_t(std::max<off_t>(file_bytes, 0));
    std::fflush(nullptr);
    const pid_t child = fork();
    if (child < 0) return ChildRead::ok;  // no child: read it here, as before
    if (child == 0) {
        const int null = open("/dev/null", O_WRONLY);
        if (sink) {
            dup2(fileno(sink), 2);
        } else if (null >= 0) {
            dup2(null, 2);
        }
        if (null >= 0) dup2(null, 1);
        // The child dies of the signal, whatever handler this process had installed: a
        // sanitizer's or libFuzzer's would turn the abort into an ordinary exit (that is how
        // `make fuzz` still crashed after the check first landed).
        for (const int deadly : {SIGABRT, SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGALRM}) {
            signal(deadly, SIG_DFL);
        }
        if (limit_child_memory) {
            const rlimit limit = {memory, memory};
            setrlimit(RLIMIT_AS, &limit);
        }
        alarm(child_seconds);
        bool read = false;
        try {
            gdcm::ImageReader reader;
            reader.SetFileName(file.c_str());
            read = reader.Read();
            SampleType type;
            const gdcm::Image& image = reader.GetImage();
            if (read && sample_type_of(image.GetPixelFormat(), &type)) {
                const unsigned* dims = image.GetDimensions();
                std::vector<char> pixels;
                try {
                    decode_pixels(reader, file, dims[0], dims[1], type, pixels);
                } catch (const InputError&) {
                    // Not decoded: attributes the parent refuses by name before decoding.
                }
            }
        } catch (...) {  // std::bad_alloc at the memory limit
        }
        _exit(read ? read_ok : read_failed);
    }
    int status = 0;
    while (waitpid(child, &status, 0) < 0 && errno == EINTR) {
    }
    if (WIFEXITED(status) && WEXITSTATUS(status) == read_ok) return ChildRead::ok;
    if (WIFEXITED(status) && WEXITSTATUS(status) == read_failed) return ChildRead::unreadable;
    return ChildRead::damaged;
}

std::string text_of(const gdcm::DataSet& data, uint16_t group, uint16_t element) {
    const gdcm::Tag tag(group, element);
    if (!data.FindDataElement(tag)) return "";
    const gdcm::ByteValue* value = data.GetDataElement(tag).GetByteValue();
    if (!value) return "";
    std::string text(value->GetPointer(), value->GetLength());
    while (!text.empty() && (text.back() == ' ' || text.back() == '\0')) text.pop_back();
    return text;
}

}  // namespace

Volume load_dicom_series(const std::string& folder) {
    gdcm::Trace::SetDebug(false);
    gdcm::Trace::SetWarning(false);
    gdcm::Trace::SetError(false);
    const std::string prefix = "'" + folder + "' (DICOM series): ";

    std::vector<std::string> files;
    DIR* directory = opendir(folder.c_str());
    if (!directory) throw InputError("cannot open '" + folder + "': " + std::strerror(errno));
    while (const dirent* entry = readdir(directory)) {
        const std::string name = entry->d_name;
        if (name.empty() || name[0] == '.' || name == "DICOMDIR") continue;
        const std::string path = folder + "/" + name;
        struct stat info {};
        if (stat(path.c_str(), &info) == 0 && S_ISREG(info.st_mode)) files.push_back(path);
        if (files.size() > max_slices) break;
    }
    closedir(directory);
    if (files.empty()) {
        throw InputError("'" + folder + "' is a folder, not a file, and holds no DICOM slices");
    }
    if (files.size() > max_slices) {
        throw InputError(prefix + "holds more than " + std::to_string(max_slices) + " files");
    }
    std::sort(files.begin(), files.end());

    std::vector<Slice> slices;
    std::string series;
    unsigned columns = 0, rows = 0;
    double row_direction[3] = {1, 0, 0}, column_direction[3] = {0, 1, 0}, normal[3] = {0, 0, 1};
    double spacing[3] = {1, 1, 1};
    double slope = 1, intercept = 0;
    SampleType type = SampleType::int16;
    ValueRange range;  // of the rescaled values, over every slice (for the volume's map)
    std::vector<char> pixels;  // one slice at a time: nothing of a slice is kept but its place
    // Pass 1: every file checked in a child, then read here; its place and its values' range.
    for (const std::string& file : files) {
        struct stat info {};
        stat(file.c_str(), &info);
        std::FILE* sink = std::tmpfile();
        const ChildRead first = read_in_child(file, info.st_size, sink);
        const std::string said = last_line(sink);
        if (sink) std::fclose(sink);
        const std::string quoted = said.empty() ? "" : " (it said: " + said + ")";
        if (first == ChildRead::damaged) {
            throw InputError(prefix + "'" + file + "' is a damaged DICOM file (GDCM stops on it)" +
                             quoted);
        }
        if (first == ChildRead::unreadable) {
            throw InputError(prefix + "'" + file + "' is not a DICOM image GDCM can read" + quoted);
        }
        gdcm::ImageReader reader;
        reader.SetFileName(file.c_str());
        bool read = false;
        const std::string read_said = capture_stderr([&] { read = reader.Read(); });
        if (!read) {
            throw InputError(prefix + "'" + file + "' is not a DICOM image GDCM can read" +
                             (read_said.empty() ? "" : " (it said: " + read_said + ")"));
        }
        const gdcm::Image& image = reader.GetImage();
        const gdcm::DataSet& data_set = reader.GetFile().GetDataSet();
        const std::string uid = text_of(data_set, 0x0020, 0x000e);
        const unsigned* dims = image.GetDimensions();
        SampleType slice_type;
        const unsigned image_dims = image.GetNumberOfDimensions();
        if (!(image_dims == 2 || (image_dims == 3 && dims[2] == 1))) {
            throw InputError(prefix + "'" + file + "' is not a single slice");
        }
        if (image.GetPixelFormat().GetSamplesPerPixel() != 1 ||
            !sample_type_of(image.GetPixelFormat(), &slice_type)) {
            throw InputError(prefix + "'" + file + "' has pixels of type " +
                             image.GetPixelFormat().GetScalarTypeAsString() +
                             " x" + std::to_string(image.GetPixelFormat().GetSamplesPerPixel()) +
                             "; ctlab reads one grey value per pixel");
        }
        const double* cosines = image.GetDirectionCosines();
        const double* origin = image.GetOrigin();
        if (slices.empty()) {
            series = uid;
            columns = dims[0];
            rows = dims[1];
            type = slice_type;
            slope = image.GetSlope();
            intercept = image.GetIntercept();
            if (!(std::isfinite(slope) && slope != 0 && std::isfinite(intercept))) {
                throw InputError(prefix + "RescaleSlope must be a number other than 0");
            }
            for (int w = 0; w < 3; ++w) {
                row_direction[w] = cosines[w];
                column_direction[w] = cosines[3 + w];
            }
            normal[0] = row_direction[1] * column_direction[2] - row_direction[2] * column_direction[1];
            normal[1] = row_direction[2] * column_direction[0] - row_direction[0] * column_direction[2];
            normal[2] = row_direction[0] * column_direction[1] - row_direction[1] * column_direction[0];
            spacing[0] = image.GetSpacing(0);
            spacing[1] = image.GetSpacing(1);
            check_volume_size(prefix + "slices of", columns, rows, files.size());
        } else {
            if (uid != series) {
                throw InputError(prefix + "holds more than one series ('" + file +
                                 "' belongs to another): put one series in a folder");
            }
            if (dims[0] != columns || dims[1] != rows || slice_type != type) {
                throw InputError(prefix + "'" + file + "' differs in size or pixel type from '" +
                                 slices[0].file + "'");
            }
            if (image.GetSlope() != slope || image.GetIntercept() != intercept) {
                throw InputError(prefix + "'" + file + "' has another rescale slope or intercept "
                                 "than '" + slices[0].file + "'");
            }
        }
        Slice slice;
        slice.file = file;
        for (int w = 0; w < 3; ++w) slice.origin[w] = origin[w];
        slice.position = origin[0] * normal[0] + origin[1] * normal[1] + origin[2] * normal[2];
        decode_pixels(reader, prefix + "'" + file + "'", columns, rows, type, pixels);
        scan_samples(range, reinterpret_cast<const unsigned char*>(pixels.data()),
                     size_t(columns) * rows, type, host_endian(), slope, intercept);
        slices.push_back(std::move(slice));
    }
    std::stable_sort(slices.begin(), slices.end(),
                     [](const Slice& a, const Slice& b) { return a.position < b.position; });
    for (size_t n = 1; n < slices.size(); ++n) {
        if (std::fabs(slices[n].position - slices[n - 1].position) < 1e-6) {
            throw InputError(prefix + "'" + slices[n - 1].file + "' and '" + slices[n].file +
                             "' are at the same position: two series mixed, or a copy");
        }
    }
    // Even steps from slice to slice: a missing slice (or two series' slices interleaved)
    // would be stretched over its neighbours' spacing without a word.
    if (slices.size() > 2) {
        double smallest = slices[1].position - slices[0].position;
        size_t widest = 1;
        for (size_t n = 1; n < slices.size(); ++n) {
            const double gap = slices[n].position - slices[n - 1].position;
            smallest = std::min(smallest, gap);
            if (gap > slices[widest].position - slices[widest - 1].position) widest = n;
        }
        const double widest_gap = slices[widest].position - slices[widest - 1].position;
        constexpr double gap_tolerance = 0.01;  // relative: scanners' positions round to 0.01 mm
        if (widest_gap > smallest * (1 + gap_tolerance) + 1e-4) {
            char text[160];
            std::snprintf(text, sizeof text, "%.4g mm apart, the others as close as %.4g mm",
                          widest_gap, smallest);
            throw InputError(prefix + "'" + slices[widest - 1].file + "' and '" +
                             slices[widest].file + "' are " + text +
                             ": a slice is missing (or the slices are unevenly spaced)");
        }
    }
    spacing[2] = slices.size() > 1 ? (slices.back().position - slices.front().position) /
                                         double(slices.size() - 1)
                                   : 1.0;
    for (double s : spacing) {
        if (!(s > 0) || !std::isfinite(s)) throw InputError(prefix + "pixel or slice spacing is not positive");
    }

    // Pass 2: each slice decoded again, in order, and converted into its place in the volume.
    Volume volume;
    volume.name = folder;
    volume.format = "dicom";
    volume.nx = int(columns);
    volume.ny = int(rows);
    volume.nz = int(slices.size());
    volume.sx = spacing[0];
    volume.sy = spacing[1];
    volume.sz = spacing[2];
    volume.map = choose_map(range, folder);
    resize_dense(volume);
    const size_t slice_values = size_t(columns) * rows;
    for (size_t n = 0; n < slices.size(); ++n) {
        gdcm::ImageReader reader;
        reader.SetFileName(slices[n].file.c_str());
        bool read = false;
        capture_stderr([&] { read = reader.Read(); });
        const gdcm::Image& image = reader.GetImage();
        if (!read || image.GetDimensions()[0] != columns || image.GetDimensions()[1] != rows) {
            throw InputError(prefix + "'" + slices[n].file + "' changed while it was read");
        }
        decode_pixels(reader, prefix + "'" + slices[n].file + "'", columns, rows, type, pixels);
        convert_samples(volume.data.data() + n * slice_values,
                        reinterpret_cast<const unsigned char*>(pixels.data()), slice_values, type,
                        host_endian(), slope, intercept, volume.map);
    }
    update_range(volume);
    Directions directions{};
    for (int w = 0; w < 3; ++w) {
        directions.axis[0][w] = row_direction[w];
        directions.axis[1][w] = column_direction[w];
        directions.axis[2][w] = normal[w];
    }
    check_axes_independent(directions, prefix, "its ImageOrientationPatient");
    reorient_to_lab(volume, directions, PatientFrame::lps);
    return volume;
}

}  // namespace ctlab
