// SPDX-License-Identifier: BSD-3-Clause
#include "core/solvers/dimacs_graph.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <string>

namespace commerge {
namespace {

// Splits the next whitespace-separated token off `line`; empty when none is left.
std::string_view NextToken(std::string_view* line) {
  std::size_t b = 0;
  while (b < line->size() && ((*line)[b] == ' ' || (*line)[b] == '\t' || (*line)[b] == '\r')) ++b;
  std::size_t e = b;
  while (e < line->size() && (*line)[e] != ' ' && (*line)[e] != '\t' && (*line)[e] != '\r') ++e;
  const std::string_view token = line->substr(b, e - b);
  line->remove_prefix(e);
  return token;
}

bool ParseInt64(std::string_view token, long long* out) {
  if (token.empty() || token.size() > 20) return false;
  const std::string s(token);
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(s.c_str(), &end, 10);
  if (errno != 0 || end != s.c_str() + s.size()) return false;
  *out = v;
  return true;
}

bool ParseDouble(std::string_view token, double* out) {
  if (token.empty() || token.size() > 64) return false;
  const std::string s(token);
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (errno != 0 || end != s.c_str() + s.size() || !std::isfinite(v)) return false;
  *out = v;
  return true;
}

}  // namespace

Result<DimacsGraph> ParseDimacsGraph(std::string_view text, std::string_view source_name) {
  DimacsGraph graph;
  const std::string name(source_name);
  bool have_p = false;
  long long declared_edges = 0;
  std::size_t line_no = 0;
  auto error = [&](const std::string& what) {
    return Status(StatusCode::kDataLoss, name + ":" + std::to_string(line_no) + ": " + what);
  };
  while (!text.empty()) {
    ++line_no;
    const std::size_t nl = text.find('\n');
    std::string_view line = text.substr(0, nl);
    text.remove_prefix(nl == std::string_view::npos ? text.size() : nl + 1);
    std::string_view rest = line;
    const std::string_view kind = NextToken(&rest);
    if (kind.empty()) continue;
    if (kind == "c") {
      const std::string_view tag = NextToken(&rest);
      if (tag != "bipartite" && tag != "robots") continue;
      if (!graph.block_sizes.empty()) return error("a second block comment (c bipartite / c robots)");
      long long count = 2;
      if (tag == "robots" && (!ParseInt64(NextToken(&rest), &count) || count < 1 || count > 1024)) {
        return error("'c robots K ...' needs a robot count K in 1..1024");
      }
      for (long long r = 0; r < count; ++r) {
        long long size = 0;
        if (!ParseInt64(NextToken(&rest), &size) || size < 0 || size > kMaxDimacsVertices) {
          return error("block comment: expected " + std::to_string(count) + " block sizes");
        }
        graph.block_sizes.push_back(static_cast<int>(size));
      }
      continue;
    }
    if (kind == "p") {
      if (have_p) return error("a second 'p' line");
      const std::string_view format = NextToken(&rest);
      long long n = 0;
      if ((format != "edge" && format != "col") || !ParseInt64(NextToken(&rest), &n) ||
          !ParseInt64(NextToken(&rest), &declared_edges) || !NextToken(&rest).empty()) {
        return error("expected 'p edge N M'");
      }
      if (n < 0 || n > kMaxDimacsVertices) {
        return error("vertex count " + std::to_string(n) + " outside 0.." + std::to_string(kMaxDimacsVertices));
      }
      // Every edge line needs at least 6 bytes ("e 1 2\n"): a larger M cannot be in this text.
      if (declared_edges < 0 || static_cast<unsigned long long>(declared_edges) > text.size() / 6 + 1) {
        return error("edge count " + std::to_string(declared_edges) + " cannot fit in the remaining " +
                     std::to_string(text.size()) + " bytes (truncated file?)");
      }
      graph.num_vertices = static_cast<int>(n);
      graph.edges.reserve(static_cast<std::size_t>(declared_edges));
      have_p = true;
      continue;
    }
    if (kind == "e" || kind == "n") {
      if (!have_p) return error("'" + std::string(kind) + "' line before the 'p' line");
      long long a = 0;
      if (!ParseInt64(NextToken(&rest), &a) || a < 1 || a > graph.num_vertices) {
        return error("vertex id outside 1.." + std::to_string(graph.num_vertices));
      }
      if (kind == "e") {
        long long b = 0;
        if (!ParseInt64(NextToken(&rest), &b) || b < 1 || b > graph.num_vertices) {
          return error("vertex id outside 1.." + std::to_string(graph.num_vertices));
        }
        if (a == b) return error("self-loop on vertex " + std::to_string(a));
        if (static_cast<long long>(graph.edges.size()) >= declared_edges) {
          return error("more 'e' lines than the " + std::to_string(declared_edges) + " declared");
        }
        graph.edges.emplace_back(static_cast<int>(a - 1), static_cast<int>(b - 1));
      } else {
        double w = 0.0;
        if (!ParseDouble(NextToken(&rest), &w)) return error("vertex weight is not a finite number");
        if (graph.vertex_weights.empty()) graph.vertex_weights.assign(static_cast<std::size_t>(graph.num_vertices), 0.0);
        graph.vertex_weights[static_cast<std::size_t>(a - 1)] = w;
      }
      if (!NextToken(&rest).empty()) return error("trailing text");
      continue;
    }
    return error("unknown line type '" + std::string(kind) + "'");
  }
  ++line_no;
  if (!have_p) return error("no 'p edge N M' line");
  if (static_cast<long long>(graph.edges.size()) != declared_edges) {
    return error("found " + std::to_string(graph.edges.size()) + " 'e' lines, the 'p' line declares " +
                 std::to_string(declared_edges) + " (truncated file?)");
  }
  if (!graph.block_sizes.empty()) {
    long long sum = 0;
    for (int s : graph.block_sizes) sum += s;
    if (sum != graph.num_vertices) {
      return error("block sizes sum to " + std::to_string(sum) + ", the graph has " +
                   std::to_string(graph.num_vertices) + " vertices");
    }
  }
  return graph;
}

}  // namespace commerge
