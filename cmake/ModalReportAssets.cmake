# ModalReportAssets.cmake — the JavaScript and CSS inlined into HTML reports
# (docs/design.md, "HTML reports"), included by lib/CMakeLists.txt.
#
# uPlot comes from the npm registry at the version and integrity pinned in
# lib/report/web/package-lock.json: `npm ci` installs it into the build
# directory at build time (once; again when the lock changes). Its minified
# script and style, and the report's own lib/report/web/report.js and
# report.css, are embedded as byte arrays in a generated source of
# modal_report. A report never fetches anything when it is opened.
include_guard(GLOBAL)

find_program(MODAL_NPM npm)
if(NOT MODAL_NPM)
  message(FATAL_ERROR
    "npm was not found. modal's HTML reports (analyze --report) inline the uPlot plotting library, which the "
    "build installs with `npm ci` from lib/report/web/package-lock.json. Install Debian's nodejs and npm "
    "packages (scripts/setup-debian.sh does), or set MODAL_NPM to an npm executable.")
endif()

function(modal_report_assets target)
  set(web_source ${PROJECT_SOURCE_DIR}/lib/report/web)
  set(web_build ${CMAKE_BINARY_DIR}/report-web)
  set(uplot_dist ${web_build}/node_modules/uplot/dist)
  file(MAKE_DIRECTORY ${web_build} ${CMAKE_BINARY_DIR}/generated)  # npm ci's working directory
  add_custom_command(
    OUTPUT ${uplot_dist}/uPlot.iife.min.js ${uplot_dist}/uPlot.min.css
    COMMAND ${CMAKE_COMMAND} -E copy ${web_source}/package.json ${web_source}/package-lock.json ${web_build}
    COMMAND ${MODAL_NPM} ci --ignore-scripts --no-audit --no-fund --loglevel=error
    COMMAND ${CMAKE_COMMAND} -E touch ${uplot_dist}/uPlot.iife.min.js ${uplot_dist}/uPlot.min.css
    WORKING_DIRECTORY ${web_build}
    DEPENDS ${web_source}/package.json ${web_source}/package-lock.json
    COMMENT "npm ci: uPlot for the HTML reports (pinned in lib/report/web/package-lock.json)"
    VERBATIM)
  set(generated ${CMAKE_BINARY_DIR}/generated/report_assets.cpp)
  set(files
    "uplot_js=${uplot_dist}/uPlot.iife.min.js" "uplot_css=${uplot_dist}/uPlot.min.css"
    "uplot_license=${web_build}/node_modules/uplot/LICENSE"
    "report_js=${web_source}/report.js" "report_css=${web_source}/report.css")
  string(REPLACE ";" "|" files_argument "${files}")
  add_custom_command(
    OUTPUT ${generated}
    COMMAND ${CMAKE_COMMAND} -DOUTPUT=${generated} -DNAMESPACE=modal::report_assets "-DFILES=${files_argument}"
            -P ${PROJECT_SOURCE_DIR}/cmake/EmbedFiles.cmake
    DEPENDS ${uplot_dist}/uPlot.iife.min.js ${uplot_dist}/uPlot.min.css ${web_source}/report.js
            ${web_source}/report.css ${PROJECT_SOURCE_DIR}/cmake/EmbedFiles.cmake
    COMMENT "Embedding the HTML report's scripts and styles"
    VERBATIM)
  target_sources(${target} PRIVATE ${generated})
endfunction()
