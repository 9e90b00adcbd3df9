// voxpack: the binary is the library dispatcher (cli.cpp) and nothing else.
#include "cli.hpp"

int main(int argc, char** argv) { return voxpack::app::runMain(argc, argv); }
