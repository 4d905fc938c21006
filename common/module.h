// module.h: the parts of ctlab that need big libraries (the volume formats' GDCM, nifticlib,
// teem and zlib; the window's SDL2) live in shared modules beside the step binaries, opened
// only when a run needs them. A phantom or raw run, --help and every headless render start
// without mapping any of those libraries: a step process starts in about a millisecond, not
// twenty (most of which was the loader and GDCM's static dictionaries).
#pragma once
#include <string>

namespace ctlab {

// The module `file_name` ("ctlab_formats.so") from the folder of the running program, opened
// once per process; returns the address of its entry point `symbol`. `needed_for` says what
// the module is for ("to read NIfTI files"). A module or one of its libraries that cannot be
// loaded throws InputError with one line naming it and the Debian package that provides it.
void* module_entry(const char* file_name, const char* symbol, const std::string& needed_for);

// The folder the running program's binary is in ("" when /proc/self/exe cannot be read).
std::string program_folder();

// The Debian package that ships a shared library named in a loader's message
// ("libgdcmMSFF.so.3.0: cannot open shared object file" -> "libgdcm-dev"), or "".
std::string package_of_library(const std::string& loader_message);

}  // namespace ctlab
