#pragma once

// One entry point for "measured data" wherever it comes from: a dataset CSV or a tabulated file
// (MERL *.binary / *.merl, gonio *.gtab), and the matching exports to the MERL format.

#include <string>

#include "gonio/base/error.h"
#include "gonio/brdf/brdf.h"
#include "gonio/brdf/dataset.h"
#include "gonio/brdf/resample.h"

namespace gonio::brdf {

/// Loads samples by extension: *.csv through read_dataset_csv() (strict unless csv.keep_going: a
/// bad row is an error naming file:line:column and the range); a table through read_table_file()
/// and table_to_dataset() (one sample per valid bin above the horizon, at the bin centre, in 1/sr).
/// Other extensions are an error naming the path.
Expected<Dataset> load_samples(const std::string& path, const DatasetReadOptions& csv = {});

/// Tabulates any BRDF (model or table) at the bin centres of the MERL grid and writes it to path
/// (*.binary / *.merl; a *.gtab path takes options.grid as given).
Expected<TabulateReport> export_merl(const std::string& path,
                                     const Brdf& brdf,
                                     const TabulateOptions& options = {});

/// Resamples scattered samples onto a table (resample_dataset()) and writes it to path. The report
/// counts the bins left without data.
Expected<ResampleReport> export_merl(const std::string& path,
                                     const Dataset& data,
                                     const ResampleOptions& options = {});

}  // namespace gonio::brdf
