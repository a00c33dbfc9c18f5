# Finds a Python 3 interpreter that has numpy, its development files and
# pybind11, for the Python module (src/python). Sets CED_PYTHON_AVAILABLE.
#
# `python3` first on PATH may be an interpreter without the system's numpy
# (pyenv, conda...), while Debian's python3-numpy and pybind11-dev serve
# /usr/bin/python3. Unless Python3_EXECUTABLE is given, the first of
# `python3` on PATH and /usr/bin/python3 that imports numpy is used; the
# tests run with the same interpreter.
set(CED_PYTHON_AVAILABLE OFF)
if(NOT Python3_EXECUTABLE AND PYTHON_EXECUTABLE)  # scikit-build passes PYTHON_EXECUTABLE
  set(Python3_EXECUTABLE ${PYTHON_EXECUTABLE})
endif()
if(NOT Python3_EXECUTABLE)
  find_program(CED_PATH_PYTHON3 python3)
  foreach(candidate ${CED_PATH_PYTHON3} /usr/bin/python3)
    if(EXISTS ${candidate})
      execute_process(COMMAND ${candidate} -c "import numpy" RESULT_VARIABLE has_numpy OUTPUT_QUIET ERROR_QUIET)
      if(has_numpy EQUAL 0)
        set(Python3_EXECUTABLE ${candidate} CACHE FILEPATH "The Python interpreter of the module and its tests")
        break()
      endif()
    endif()
  endforeach()
endif()
if(Python3_EXECUTABLE)
  find_package(Python3 COMPONENTS Interpreter Development.Module NumPy QUIET)
  if(Python3_FOUND AND Python3_NumPy_FOUND)
    set(PYBIND11_FINDPYTHON ON)
    find_package(pybind11 2.6 CONFIG QUIET)
    if(pybind11_FOUND)
      set(CED_PYTHON_AVAILABLE ON)
      message(STATUS "Python for the module (CED_PYTHON): ${Python3_EXECUTABLE} (Python ${Python3_VERSION}, numpy ${Python3_NumPy_VERSION})")
    endif()
  endif()
endif()
if(NOT CED_PYTHON_AVAILABLE)
  message(STATUS "Python module not built: needs an interpreter with numpy, its headers and pybind11 "
                 "(Debian: python3-dev python3-numpy pybind11-dev), or -DPython3_EXECUTABLE=...")
endif()
