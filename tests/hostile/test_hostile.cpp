// Hostile input, generated: every case is a class (deep nesting of each kind,
#include <cmath>
// at many depths, in a scene file and on the command line), and every outcome
// is a clear refusal or an answer — never a crash. docs/design.md section 9
// lists the guarantees these tests hold the program to.
#include "modal/expression.hpp"
#include "modal/pipeline.hpp"
#include "modal/scene.hpp"

#include "program.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <string>
#include <vector>

namespace {

using modal::test::Outcome;

class Hostile : public modal::test::ProgramTest {
 protected:
  Hostile() : ProgramTest("modal_hostile_") {}
  std::string write(const std::string& name, const std::string& text) const {
    const std::string path = (dir / name).string();
    std::ofstream(path, std::ios::binary) << text;
    return path;
  }
};

// An expression nested `depth` levels deep in one of four ways.
std::string nested(const std::string& kind, int depth) {
  std::string s;
  if (kind == "parentheses") return std::string(static_cast<std::size_t>(depth), '(') + "1" +
                                    std::string(static_cast<std::size_t>(depth), ')');
  if (kind == "signs") {
    for (int i = 0; i < depth; ++i) s += "-";
    return s + "1";
  }
  if (kind == "powers") {
    for (int i = 0; i < depth; ++i) s += "1^";
    return s + "1";
  }
  for (int i = 0; i < depth; ++i) s += "sin(";  // calls
  return s + "1" + std::string(static_cast<std::size_t>(depth), ')');
}

const std::vector<std::string> kinds{"parentheses", "signs", "powers", "calls"};
const std::vector<int> depths{1, 50, modal::max_expression_depth - 1, modal::max_expression_depth + 1, 1000, 14000,
                              100000};

TEST(hostile_expressions, NestingIsBoundedNotAStackOverflow) {
  for (const std::string& kind : kinds)
    for (int depth : depths) {
      const std::string text = nested(kind, depth);
      // Each kind adds one level per repetition, plus the outermost operand.
      const bool fits = depth + 1 <= modal::max_expression_depth;
      try {
        const double v = modal::Expression::parse(text, {}).evaluate(std::vector<double>{});
        EXPECT_TRUE(fits) << kind << " " << depth << " was accepted";
        EXPECT_TRUE(std::isfinite(v));
      } catch (const modal::ExpressionError& e) {
        EXPECT_FALSE(fits) << kind << " " << depth << ": " << e.what();
        EXPECT_NE(std::string(e.what()).find("nested more than"), std::string::npos) << e.what();
      }
    }
}

TEST_F(Hostile, DeepExpressionsInASceneAndOnTheCommandLineAreRefusedWithTheirPlace) {
  const std::string head = "title = \"deep\"\n[parameters]\ng = 1\n";
  for (const std::string& kind : kinds)
    for (int depth : {modal::max_expression_depth + 1, 14000}) {
      const std::string expression = nested(kind, depth);
      const std::string scene = write("deep.toml", head + "m = \"" + expression +
                                                       "\"\n[[body]]\nname = \"p\"\njoint = \"hinge\"\n"
                                                       "axis = [0, 1, 0]\nmass = 1\ncom = [0, 0, -1]\n");
      Outcome r = run({"analyze", scene});
      EXPECT_EQ(r.status, 2) << kind << " " << depth << ": " << r.err;
      EXPECT_NE(r.err.find("deep.toml:4:"), std::string::npos) << r.err.substr(0, 300);
      EXPECT_NE(r.err.find("parameters.m"), std::string::npos) << r.err.substr(0, 300);
      EXPECT_NE(r.err.find("nested more than"), std::string::npos) << r.err.substr(0, 300);
      EXPECT_TRUE(r.out.empty());

      const std::string plain = write("plain.toml", head + "m = 1\n[[body]]\nname = \"p\"\njoint = \"hinge\"\n"
                                                           "axis = [0, 1, 0]\nmass = \"m\"\ncom = [0, 0, -1]\n");
      r = run({"analyze", plain, "--set", "m=" + expression});
      EXPECT_EQ(r.status, 2) << kind << " " << depth << ": " << r.err.substr(0, 300);
      EXPECT_NE(r.err.find("--set"), std::string::npos) << r.err.substr(0, 300);
      EXPECT_NE(r.err.find("nested more than"), std::string::npos) << r.err.substr(0, 300);
    }
}

}  // namespace
