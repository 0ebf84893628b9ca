#include "gonio/brdf/samples_io.h"

#include "gonio/brdf/merl.h"

namespace gonio::brdf {
namespace {

bool ends_with(const std::string& s, const std::string& suffix) {
    return s.size() >= suffix.size() &&
           s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

}  // namespace

Expected<Dataset> load_samples(const std::string& path) {
    if (ends_with(path, ".csv")) {
        return read_dataset_csv(path);
    }
    if (is_table_path(path)) {
        Expected<TabulatedBrdf> table = read_table_file(path);
        if (!table) {
            return make_error(table.error().message);
        }
        Dataset data = table_to_dataset(*table);
        data.source = path;
        return data;
    }
    return make_error(path + ": unknown sample file type (expected .csv, .binary, .merl or .gtab)");
}

Expected<TabulateReport> export_merl(const std::string& path,
                                     const Brdf& brdf,
                                     const TabulateOptions& options) {
    TabulateReport report;
    const TabulatedBrdf table = tabulate(brdf, options, &report);
    Expected<void> w = write_merl(path, table);
    if (!w) {
        return make_error(w.error().message);
    }
    return report;
}

Expected<ResampleReport> export_merl(const std::string& path,
                                     const Dataset& data,
                                     const ResampleOptions& options) {
    ResampleReport report;
    Expected<TabulatedBrdf> table = resample_dataset(data, options, &report);
    if (!table) {
        return make_error(table.error().message);
    }
    Expected<void> w = write_merl(path, *table);
    if (!w) {
        return make_error(w.error().message);
    }
    return report;
}

}  // namespace gonio::brdf
