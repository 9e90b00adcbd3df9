// Forced include of voxpack_ingest in the clang fuzz build only (fuzz/CMakeLists.txt).
// Debian's ITK 5.2 ships the itk_compiler_detection.h that CMake generated for GCC alone:
// under clang it stops with "#error Unsupported compiler". clang 14 has every C++11/14
// feature that header tests, so it is read once here as GCC 12 would see it; its include
// guard then makes ITK's own #include of it a no-op. The compiler macros are restored.
#pragma once
#pragma push_macro("__clang__")
#pragma push_macro("__GNUC__")
#pragma push_macro("__GNUC_MINOR__")
#undef __clang__
#undef __GNUC__
#undef __GNUC_MINOR__
#define __GNUC__ 12
#define __GNUC_MINOR__ 2
#include <itk_compiler_detection.h>
#pragma pop_macro("__GNUC_MINOR__")
#pragma pop_macro("__GNUC__")
#pragma pop_macro("__clang__")
