// snowsim: simulates snow and renders it off-screen.
#include "app/commands.h"

int main(int argc, char** argv) {
  return snowsim::runCommandLine(argc, argv);
}
