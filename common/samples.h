// samples.h: the pieces of store_samples (common/volume.cpp), for loaders that read a file's
// samples in chunks (common/file_input.cpp): gather the range over every chunk, choose the map
// once, then convert chunk by chunk. The same code as store_samples, so both give one result.
#pragma once
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include "volume.h"

namespace ctlab {

// The file values' range, gathered over one or more chunks.
struct ValueRange {
    double low = std::numeric_limits<double>::infinity();
    double high = -std::numeric_limits<double>::infinity();
    bool whole = true;   // every value a whole number
    bool finite = true;  // no NaN, no infinity
};

// Adds count samples (times slope plus inter) to the range.
void scan_samples(ValueRange& range, const unsigned char* bytes, size_t count, SampleType type,
                  Endian endian, double slope, double inter);

// The map from int16 volume values to file values (see ValueMap); InputError for NaN,
// infinities or a range too wide.
ValueMap choose_map(const ValueRange& range, const std::string& name);

// Converts count samples into out through the map.
void convert_samples(int16_t* out, const unsigned char* bytes, size_t count, SampleType type,
                     Endian endian, double slope, double inter, const ValueMap& map);

}  // namespace ctlab
