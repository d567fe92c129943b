"""Reports: report.md, report.html and figures from a campaign result object.

Formatting only (:mod:`truthbench.report.accuracy`, :mod:`truthbench.report.format`,
:mod:`truthbench.report.html`): the numbers, tables and figures come from
:class:`~truthbench.campaign.results.CampaignResult`; nothing here reruns numerics.
"""
