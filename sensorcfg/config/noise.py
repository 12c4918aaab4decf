"""Noise stage configs (interim: gaussian only; the noise issue adds the rest of the table)."""

from __future__ import annotations

from typing import Annotated, Literal, Union

from pydantic import BaseModel, ConfigDict, Field


class GaussianStage(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")
    type: Literal["gaussian"] = Field(description="Additive white noise drawn from N(mean, std^2) per value.")
    mean: float = Field(0.0, description="Mean of the noise.", examples=[0.0])
    std: float = Field(ge=0, description="Standard deviation of the noise, in the sensor's units.", examples=[0.01])


NoiseStage = Annotated[Union[GaussianStage], Field(discriminator="type")]
