// vmsim: the command-line program. A thin layer over the libraries: it parses arguments, calls
// the libraries, prints, and turns errors into exit codes.
#include <CLI/CLI.hpp>
#include <iostream>

int main(int argc, char** argv) {
  CLI::App app{"vmsim: virtual machining simulator"};
  app.require_subcommand(1);
  CLI11_PARSE(app, argc, argv);
  return 0;
}
