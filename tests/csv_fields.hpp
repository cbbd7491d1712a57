// Reading back the CSV the report stage writes, for the tests.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

namespace modal::test {

// Splits one CSV record (RFC 4180, no embedded line breaks).
inline std::vector<std::string> fields(const std::string& line) {
  std::vector<std::string> out(1);
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        out.back() += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        out.back() += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      out.emplace_back();
    } else {
      out.back() += c;
    }
  }
  return out;
}

// A CSV file read back: header and rows keyed by column name.
using Row = std::map<std::string, std::string>;
struct Csv {
  std::vector<std::string> header;
  std::vector<Row> rows;
};

inline Csv read_csv(const std::filesystem::path& p) {
  Csv csv;
  std::ifstream in(p);
  EXPECT_TRUE(in.good()) << "missing " << p;
  std::string line;
  if (!std::getline(in, line)) return csv;
  csv.header = fields(line);
  while (std::getline(in, line)) {
    const auto f = fields(line);
    EXPECT_EQ(f.size(), csv.header.size()) << p << ": " << line;
    Row row;
    for (std::size_t i = 0; i < f.size() && i < csv.header.size(); ++i) row[csv.header[i]] = f[i];
    csv.rows.push_back(row);
  }
  return csv;
}

// The number in `column` of `row` (NaN when empty; a failure when there is no such column).
inline double number(const Row& row, const std::string& column) {
  const auto it = row.find(column);
  EXPECT_NE(it, row.end()) << "no column " << column;
  if (it == row.end() || it->second.empty()) return std::nan("");
  return std::strtod(it->second.c_str(), nullptr);
}

}  // namespace modal::test
