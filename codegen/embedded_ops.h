// The text of the op headers (ops/*.h) and the kernels' device helpers (codegen/*.cuh),
// embedded into the library at build time by
// codegen/embed_headers.cmake, so that generated kernels compile exactly the op bodies
// the CPU interpreter runs, with no source tree at run time.
#pragma once

namespace ssc {

struct EmbeddedFile {
  const char* path;  // e.g. "ops/elasticity.h"
  const char* text;
};

extern const EmbeddedFile kEmbeddedOps[];
extern const int kEmbeddedOpsCount;

}  // namespace ssc
