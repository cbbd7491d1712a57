// lib/report/report_assets.hpp — the files inlined into HTML reports, embedded
// at build time (cmake/ModalReportAssets.cmake generates their definitions):
// uPlot's script and style, from the npm package pinned in
// lib/report/web/package-lock.json, and the report's own script and style
// (lib/report/web/report.js, report.css).
#pragma once

#include <cstddef>

namespace modal::report_assets {

extern const unsigned char uplot_js[];
extern const std::size_t uplot_js_size;
extern const unsigned char uplot_css[];
extern const std::size_t uplot_css_size;
extern const unsigned char uplot_license[];  // MIT: its notice goes with every copy
extern const std::size_t uplot_license_size;
extern const unsigned char report_js[];
extern const std::size_t report_js_size;
extern const unsigned char report_css[];
extern const std::size_t report_css_size;

}  // namespace modal::report_assets
