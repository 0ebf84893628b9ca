#include "gonio/base/data_path.h"

#include <sys/stat.h>

#include <cstdlib>

namespace gonio {
namespace {

bool is_file(const std::string& path) {
    struct stat st {};
    return ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

}  // namespace

Expected<std::string> find_data_file(const std::string& relative) {
    std::string tried;
    if (const char* env = std::getenv("GONIO_DATA_DIR"); env != nullptr && *env != '\0') {
        const std::string p = std::string(env) + "/" + relative;
        if (is_file(p)) {
            return p;
        }
        tried += p + " ($GONIO_DATA_DIR), ";
    }
    const std::string p = std::string(GONIO_DATA_DIR) + "/" + relative;
    if (is_file(p)) {
        return p;
    }
    tried += p;
    return make_error("data file \"" + relative + "\" not found (tried " + tried + ")");
}

}  // namespace gonio
