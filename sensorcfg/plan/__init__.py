"""The suite plan: what an engine executes, compiled once from a suite, a model and a batch size.

Records (`plan.records`) hold integers and read-only arrays only; docs/architecture.md ("The suite plan")
says what each holds and what an engine must do with it.
"""

from .compile import compile_plan
from .noise import StepEpisode, episode, redrawn
from .records import (DrawnSteps, DrawnTiming, FixedTiming, NoiseProgram, NoiseStep, PlainOutput, ReadTable,
                      ReducedOutput, ReductionBlock, ResetDraw, SensorRecord, Source, SuitePlan)

__all__ = ["DrawnSteps", "DrawnTiming", "FixedTiming", "NoiseProgram", "NoiseStep", "PlainOutput", "ReadTable",
           "ReducedOutput", "ReductionBlock", "ResetDraw", "SensorRecord", "Source", "StepEpisode", "SuitePlan",
           "compile_plan", "episode", "redrawn"]
