// lib/report/html_page.hpp — the pieces every HTML report shares (internal to
// modal_report; docs/design.md, "HTML reports"): the page skeleton with the
// inlined assets, text made safe for HTML and for a <script> element, and a
// CSV writer's text as a table the page's script renders.
#pragma once

#include <cstddef>
#include <limits>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

namespace modal::html {

using Json = nlohmann::ordered_json;

// JSON inside <script>: "</" would end the element; "<\/" reads the same.
std::string script_safe(std::string text);
std::string escape(std::string_view text);

// The whole page: uPlot's notice, style and script, the report's style and
// script, `data` (JSON with a "kind" the script dispatches on) in
// #modal-data and `drawing` (JSON or "null") in #modal-drawing.
// The heading is `title`, the document's title "title — what"; `generator`
// names the command, e.g. "modal sweep --report".
std::string page(const std::string& title, const std::string& what, const std::string& generator, const Json& data,
                 const std::string& drawing = "null");

// A CSV writer's output as {"columns": [...], "rows": [[...], ...],
// "total_rows": N}: the fields exactly as written (quoted fields unquoted),
// at most `max_rows` rows kept. Tables in reports are made this way so that
// they show the CSV's own numbers.
Json csv_table(std::string_view csv, std::size_t max_rows = std::numeric_limits<std::size_t>::max());

}  // namespace modal::html
