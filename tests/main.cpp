// main.cpp: doctest's main. Every other tests/*.cpp file only includes doctest.h.
#define DOCTEST_CONFIG_IMPLEMENT_WITH_MAIN
#include <doctest/doctest.h>
