// toml++'s implementation, compiled once. Everywhere else the header is
// declarations only (TOML_HEADER_ONLY=0, a project argument): as a header-only
// library it added about a second to each of the ~30 files that include it.
#define TOML_IMPLEMENTATION
#include <toml++/toml.h>
