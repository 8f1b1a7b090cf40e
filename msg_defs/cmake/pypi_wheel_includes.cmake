# Include directories of the ROS 2 Jazzy wheels from PyPI, pointed at this interpreter.
#
# The message wheels on PyPI export, in their <pkg>::<pkg>__rosidl_generator_py targets,
# the Python and NumPy include directories of the machine that built them
# (/opt/python/cp311-cp311/...).  CMake refuses, at its generate step, an imported target
# whose include directory does not exist.  Included from CMakeLists.txt, this file defers
# a call to the end of the configure step that replaces each such missing directory in
# every imported target by the include directory of the Python that this build found
# (Python3_INCLUDE_DIRS, Python3_NumPy_INCLUDE_DIRS: the venv's interpreter and numpy).
# Nothing outside the build folder is written.  On a full ROS install the exported
# directories exist, and nothing is changed.

function(_pypi_wheel_fix_includes_in dir)
  get_property(targets DIRECTORY "${dir}" PROPERTY IMPORTED_TARGETS)
  foreach(target IN LISTS targets)
    get_target_property(includes "${target}" INTERFACE_INCLUDE_DIRECTORIES)
    if(NOT includes)
      continue()
    endif()
    set(fixed "")
    set(changed FALSE)
    foreach(inc IN LISTS includes)
      if(NOT EXISTS "${inc}" AND inc MATCHES "/numpy/_?core/include$")
        list(APPEND fixed ${Python3_NumPy_INCLUDE_DIRS})
        set(changed TRUE)
      elseif(NOT EXISTS "${inc}" AND inc MATCHES "/include/python3\\.[0-9]+$")
        list(APPEND fixed ${Python3_INCLUDE_DIRS})
        set(changed TRUE)
      else()
        list(APPEND fixed "${inc}")
      endif()
    endforeach()
    if(changed)
      set_target_properties("${target}" PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${fixed}")
    endif()
  endforeach()
  get_property(subdirs DIRECTORY "${dir}" PROPERTY SUBDIRECTORIES)
  foreach(sub IN LISTS subdirs)
    _pypi_wheel_fix_includes_in("${sub}")
  endforeach()
endfunction()

function(_pypi_wheel_fix_includes)
  if(NOT Python3_INCLUDE_DIRS OR NOT Python3_NumPy_INCLUDE_DIRS)
    find_package(Python3 REQUIRED COMPONENTS Interpreter Development.Module NumPy)
  endif()
  _pypi_wheel_fix_includes_in("${CMAKE_SOURCE_DIR}")
endfunction()

cmake_language(DEFER DIRECTORY "${CMAKE_SOURCE_DIR}" CALL _pypi_wheel_fix_includes)
